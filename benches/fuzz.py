"""The fuzz campaign of issue 13: random cases from tests/python/fuzzing.py for a given
time, each in a worker process; prints the counts of outcomes and every distinct finding
(a crash, a hang, a foreign exception or a non-finite number), and writes them to
benches/results/fuzz.md.

    python benches/fuzz.py --minutes 30
"""

from __future__ import annotations

import argparse
import collections
import itertools
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

import fuzzing  # noqa: E402
from hypothesis import HealthCheck, Phase, given, seed, settings  # noqa: E402


def campaign(minutes: float, first_seed: int) -> tuple[collections.Counter, dict[str, str]]:
    """Batches of 100 generated cases (no shrinking) with seeds from ``first_seed`` on, until the
    time is up."""
    counts: collections.Counter = collections.Counter()
    findings: dict[str, str] = {}
    worker = fuzzing.Worker()
    end = time.monotonic() + 60.0 * minutes

    @settings(max_examples=100, deadline=None, database=None, phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @given(case=fuzzing.cases())
    def batch(case):
        if time.monotonic() > end:
            return
        outcome = worker.run(case)
        kind = outcome.split(":")[0]
        counts[kind] += 1
        if fuzzing.finding(outcome) and outcome not in findings:
            findings[outcome] = fuzzing.describe(case)
            print(f"FINDING {outcome}\n  {findings[outcome]}", flush=True)

    try:
        for k in itertools.count(first_seed):
            if time.monotonic() >= end:
                break
            seed(k)(batch)()
    finally:
        worker.close()
    return counts, findings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    start = time.monotonic()
    counts, findings = campaign(args.minutes, args.seed)
    total = sum(counts.values())
    lines = ["# Fuzz campaign", "", f"`python benches/fuzz.py --minutes {args.minutes:g} --seed {args.seed}` on "
             f"{platform.processor() or platform.machine()}, Python {platform.python_version()}: {total} cases in "
             f"{(time.monotonic() - start) / 60:.1f} min.", "", "| outcome | cases |", "|---|---|"]
    lines += [f"| {kind} | {n} |" for kind, n in counts.most_common()]
    lines += ["", f"Findings: {len(findings)}."] + [f"- `{outcome[:300]}`" for outcome in findings]
    (ROOT / "benches" / "results" / "fuzz.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
