"""Fixtures of the control tests."""

import pytest

from inkarm.control import compiled
from tests.compiled import compiled_or_skip


@pytest.fixture
def built():
    """The compiled member period's extension (its loader's cache cleared first), or skip."""
    compiled._load.cache_clear()
    return compiled_or_skip(compiled.member_module(), "the compiled member period")
