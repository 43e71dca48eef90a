"""The farm: a shot's steps on many hosts through dagster-celery and a Redis broker (docs/production.md).

settings.py  broker URL, queues and the Celery settings every process shares (no Celery import)
executor.py  the Celery executor of the farm job: steps routed to the `cpu` or `gpu` queue
worker.py    `inbetween worker`: dagster-celery's step task in a Celery worker with our Definitions
"""
