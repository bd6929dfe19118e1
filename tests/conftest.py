"""Session fixtures shared by several test modules."""

import pytest

from notebook_runs import ExecutedNotebooks


@pytest.fixture(scope="session")
def executed_notebooks(tmp_path_factory):
    """The tutorial notebooks, each executed once per session (see ``tests/notebook_runs.py``)."""
    return ExecutedNotebooks(tmp_path_factory.mktemp("notebooks"))
