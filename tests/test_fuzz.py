"""The seeded fuzz suite of the public API (tests/fuzz_api.py): no silent wrong answer, no unclear
exception, no hang. Every case of every seed must come out ``ok``; a failure prints the case and
what went wrong. ``python tests/fuzz_api.py --seed 0 1 2 -v`` runs it by hand."""
import pytest

from fuzz_api import run

SEEDS = range(12)
CASES = 40  # valid-input cases per family and seed


@pytest.mark.parametrize("seed", SEEDS)
def test_fuzz_finds_nothing(seed):
    results = run(seed, CASES, timeout=30.0)
    bad = [f"{c.family} {c.label}: {o}: {d}" for c, o, d, _ in results if o != "ok"]
    assert not bad, "\n".join(bad[:20])
