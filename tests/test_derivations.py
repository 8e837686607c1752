"""Run the sympy derivation of the reflection constraints: every identity the solvers rely on
holds, and the genuine degrees are the corrected table of docs/solvers.md."""
import os
import runpy


def test_reflection_constraints_derivation():
    path = os.path.join(os.path.dirname(__file__), "..", "derivations", "reflection_constraints.py")
    rows = runpy.run_path(path)["main"]()
    table = {(name, what): genuine for name, what, genuine, _ in rows}
    assert table[("general (off-axis camera)", "direction")] == 8
    assert table[("axial camera", "direction")] == 6
    assert table[("cone, axial", "direction")] == 2
