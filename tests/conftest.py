"""Test-suite configuration: the tests of the one-off studies (``tests/benchmark/studies``)
carry the ``study`` marker, so ``pytest -m 'not study'`` runs the product's tests alone."""

from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parent / "benchmark" / "studies"


def pytest_collection_modifyitems(items):
    for item in items:
        if STUDIES in Path(str(item.fspath)).resolve().parents:
            item.add_marker(pytest.mark.study)
