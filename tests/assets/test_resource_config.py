"""The resources' configuration from the environment: each variable to its field, a bad value one ShotError that
names the variable and the fix."""
import pytest

from assets.resource_config import ENVIRONMENT, resource_overrides
from ops.errors import ShotError


def test_every_variable_sets_its_field_and_nothing_else():
    values = {"int": "3", "str": "torch"}
    for key, fields in ENVIRONMENT.items():
        for field, (var, kind) in fields.items():
            text = values["int"] if kind is int else ("torch" if field == "runtime" else "x")
            got = resource_overrides({var: text})
            assert got == {key: {field: int(text) if kind is int else text}}, var
    assert resource_overrides({}) == {} and resource_overrides({"INBETWEEN_DEVICE": ""}) == {}


@pytest.mark.parametrize("var, text", [("INBETWEEN_RIFE_BATCH", "0"), ("INBETWEEN_RIFE_BATCH", "two"),
                                       ("INBETWEEN_RIFE_RUNTIME", "tensorrt"), ("INBETWEEN_INPAINT_RADIUS", "-1")])
def test_a_bad_value_names_the_variable_and_the_fix(var, text):
    with pytest.raises(ShotError) as err:
        resource_overrides({var: text})
    message = str(err.value)
    assert var in message and "fix:" in message and "\n" not in message
