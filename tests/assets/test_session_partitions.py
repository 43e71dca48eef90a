"""The run's memo of Dagster's "does this dynamic partition exist?" (assets/run/session.py partitions_known)."""
from assets.run.session import partitions_known


class _Instance:
    """A Dagster instance's partition lookup, counting the queries that reach its storage."""

    def __init__(self, existing):
        self.existing, self.queries = set(existing), 0

    def has_dynamic_partition(self, partitions_def_name, partition_key):
        self.queries += 1
        return (partitions_def_name, partition_key) in self.existing


def test_a_run_asks_storage_once_per_partition_that_exists_and_every_time_for_one_that_does_not():
    instance = _Instance({("shots", "a")})
    with partitions_known(instance):
        assert all(instance.has_dynamic_partition("shots", "a") for _ in range(5))
        assert not instance.has_dynamic_partition("shots", "b")
        assert not instance.has_dynamic_partition("shots", "b")
        assert instance.queries == 3  # "a" once; "b" each time (it may be added meanwhile)
    instance.existing.clear()  # deleted after the run (the UI): the instance's own answer again
    assert not instance.has_dynamic_partition("shots", "a")
    assert instance.queries == 4
