import os

# `make test` runs the suite in one worker per core (pytest-xdist, `-n auto`). Each worker keeps
# its numpy/scipy BLAS to one thread, and so does every process a test starts: two workers with a
# BLAS pool each would ask for more cores than there are. Set before numpy is first imported (the
# workers import this file first); only under xdist, a plain `pytest` run keeps the defaults.
if os.environ.get("PYTEST_XDIST_WORKER"):
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

# CI runs a fixed-seed profile: the same examples every run
settings.register_profile("ci", derandomize=True, max_examples=40, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci" if os.environ.get("CI") else os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# The modules that take longest (seconds of one core, measured with --durations=0 and summed per
# module, 2026-11-29), run first, longest first: xdist hands out whole
# modules (`--dist loadfile`, their module fixtures computed once) in the order collected
# (`--no-loadscope-reorder`), so a long module last would leave the other worker idle at the end.
# Only the order changes; every module not named here follows in its usual order.
LONGEST_FIRST = ("test_twoview.py", "test_install.py", "test_real_images.py", "test_relative_pose.py",
                 "test_validate.py", "test_fuzz.py", "test_real_static.py", "test_render_backends.py",
                 "test_projection.py", "test_render_dataset.py", "test_linefit.py", "test_vanishing.py",
                 "test_scale.py", "test_readme.py", "test_meetings.py", "test_detect.py", "test_lines.py",
                 "test_cli.py", "test_peers.py", "test_pure_rotation.py", "test_validate_results.py",
                 "test_photometric.py", "test_relative_pose_wide.py", "test_chessboard.py")


@pytest.hookimpl(trylast=True)  # after pytest's own order within each module
def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: the rest keep their order
