"""The farm job's executor: dagster-celery's, with each step sent to the queue of the hardware it needs.

A step of a stage that runs RIFE goes to the `gpu` queue when the process
that orchestrates the run has INBETWEEN_DEVICE=cuda; every other step goes to
`cpu` (settings.queue_for). The Celery app is built from the same
`celery_settings` the workers use, and the results come back through the
broker's Redis, so a run needs nothing but the broker URL
(INBETWEEN_BROKER, or `broker` in the run config).
"""
from __future__ import annotations

import warnings
from functools import cache

import dagster as dg
from dagster import Field, Noneable, Permissive, StringSource
from dagster._core.execution.retries import RetryMode, get_retries_config

from .settings import broker_url, celery_settings, queue_for

FARM_CONFIG = {
    "broker": Field(Noneable(StringSource), is_required=False,
                    description="Celery broker URL; default: INBETWEEN_BROKER, else redis://127.0.0.1:6379/0."),
    "backend": Field(Noneable(StringSource), is_required=False,
                     description="Celery result backend URL; default: the broker's Redis."),
    "config_source": Field(Noneable(Permissive()), is_required=False,
                           description="Celery settings to override (assets/farm/settings.py celery_settings)."),
    "retries": get_retries_config(),
}


@cache
def farm_executor_class() -> type:
    """FarmExecutor, defined when a farm run starts: dagster-celery (Celery, kombu: about 0.2 s to import) is
    not imported with the Definitions, so an in-process run never loads it."""
    from dagster_celery.core_execution_loop import core_celery_execution_loop
    from dagster_celery.executor import CeleryExecutor, _submit_task

    class FarmExecutor(CeleryExecutor):
        """dagster-celery's executor whose steps go to the `cpu` or `gpu` queue by the resources they declare."""

        def execute(self, plan_context, execution_plan):
            job_def = plan_context.job.get_definition()

            def submit(app, context, step, _default_queue, priority, known_state):
                keys = job_def.get_node(step.node_handle).definition.required_resource_keys
                with warnings.catch_warnings():  # dagster-celery registers its task again for every step
                    warnings.filterwarnings("ignore", message="Task name 'execute_plan' is already registered")
                    return _submit_task(app, context, step, queue_for(keys), priority, known_state)

            return core_celery_execution_loop(plan_context, execution_plan, step_execution_fn=submit)

    return FarmExecutor


@dg.executor(name="inbetween_celery", config_schema=FARM_CONFIG,
             requirements=dg.multiple_process_executor_requirements())
def farm_executor(init_context: dg.InitExecutorContext):
    """Steps run on `inbetween worker` processes through a Celery broker (docs/production.md)."""
    config = init_context.executor_config
    broker = config.get("broker") or broker_url()
    return farm_executor_class()(retries=RetryMode.from_config(config["retries"]), broker=broker,
                        backend=config.get("backend") or broker,
                        config_source={**celery_settings(), **(config.get("config_source") or {})})
