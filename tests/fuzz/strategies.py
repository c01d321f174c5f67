"""What the fuzz tests share: the hypothesis settings (``INKARM_FUZZ_EXAMPLES=N`` for a long
campaign), extreme values, ``mutated`` (a document with values replaced, keys added or
removed) and ``check`` (the verdict of one isolated command)."""

from __future__ import annotations

import copy
import math
import os

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

# A few hundred cases in CI; INKARM_FUZZ_EXAMPLES=N for a longer run (per test).
EXAMPLES = int(os.environ.get("INKARM_FUZZ_EXAMPLES", "30"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None,
                derandomize="INKARM_FUZZ_EXAMPLES" not in os.environ,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                       HealthCheck.data_too_large])

EXTREME_NUMBERS = st.sampled_from([
    0, -1, 1, 2**31, 2**63 - 1, -(2**63), 0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e300, -1e300,
    math.inf, -math.inf, math.nan, 1e6, 1e9, -1e9, 0.5, 1e-9, 123456.789,
])
WEIRD_VALUES = st.one_of(
    EXTREME_NUMBERS,
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.booleans(),
    st.text(max_size=12),
    st.sampled_from(["", "\r", "\x00", "a\x1bb", "../../etc/passwd", "NaN", "💥"]),
    st.lists(EXTREME_NUMBERS, max_size=4),
    st.lists(st.lists(EXTREME_NUMBERS, max_size=3), max_size=3),
    st.fixed_dictionaries({}, optional={"x": EXTREME_NUMBERS}),
)


def _paths(data, prefix=()):
    """Every path to a leaf or list element of nested TOML data."""
    if isinstance(data, dict):
        for k, v in data.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


def _set(data, path, value):
    node = data
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value


@st.composite
def mutated(draw, base: dict, extra_keys=("unknown", "force_n", "kp", "px_per_mm")):
    """``base`` with a few values replaced by weird ones, keys added or removed."""
    data = copy.deepcopy(base)
    paths = list(_paths(data))
    for _ in range(draw(st.integers(1, 3))):
        action = draw(st.sampled_from(["replace", "replace", "replace", "delete", "add"]))
        path = draw(st.sampled_from(paths))
        try:
            if action == "replace":
                _set(data, path, draw(WEIRD_VALUES))
            elif action == "delete":
                node = data
                for part in path[:-1]:
                    node = node[part]
                del node[path[-1]]
            else:
                node = data
                for part in path[:-1]:
                    node = node[part]
                if isinstance(node, dict):
                    node[draw(st.sampled_from(extra_keys))] = draw(WEIRD_VALUES)
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation removed the path
        paths = list(_paths(data))
        if not paths:
            break
    return data


def check(outcome, allowed: tuple[int, ...] = (0, 2)) -> None:
    """Assert ``outcome`` behaved: exit 0, or 2 with one clean line; other ``allowed`` codes
    (1: an honest failure such as a regression) only without a traceback."""
    verdict = outcome.verdict()
    if verdict is not None and outcome.code in allowed and outcome.code not in (0, 2) \
            and "Traceback" not in outcome.stderr:
        verdict = None
    assert verdict is None, (
        f"{verdict}: inkarm {' '.join(outcome.argv)}\n{outcome.stderr[-2000:]}")
