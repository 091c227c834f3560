"""Fixtures shared by the test modules: characters and the horse clip database
are loaded once per session (loading the database retargets eleven clips)."""

import pytest

from quadsim.io.clips import load_default_database
from quadsim.skeleton.character import load_character


@pytest.fixture(scope="session")
def horse():
    """The shipped horse character."""
    return load_character("horse")


@pytest.fixture(scope="session")
def db(horse):
    """The default horse clip database."""
    return load_default_database(horse)
