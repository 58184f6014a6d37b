"""A bounded fuzz run in CI (the campaign is benches/fuzz.py): bad and extreme scenes,
TOML text, designs, settings and response names, each case in a worker process, must end
in a result with finite numbers or a FlextopError — no crash, no hang, no foreign
exception."""

import pytest
from hypothesis import HealthCheck, given, settings

import fuzzing

EXAMPLES = 4000
"""Cases per CI run (well under a minute), the same ones every run (derandomized)."""


@pytest.fixture(scope="module")
def worker():
    w = fuzzing.Worker()
    yield w
    w.close()


@settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large])
@given(case=fuzzing.cases())
def test_no_crash_no_hang_no_foreign_exception(worker, case):
    outcome = worker.run(case)
    assert not fuzzing.finding(outcome), f"{outcome}\n{fuzzing.describe(case)}"
