#!/usr/bin/env bash
# Leaves exactly one OpenCV wheel in the environment of the Python given as $1: the contrib
# one (opencv-contrib-python-headless, which has cv2.omnidir). The OpenCV wheels share one
# `cv2` folder, so a venv that held opencv-python-headless beside it (older versions of this
# project required it) loses files when either is removed: remove the others, then reinstall
# the contrib wheel's files at the version already installed.
set -euo pipefail
PY="$1"
removed=0
for other in opencv-python-headless opencv-python opencv-contrib-python; do
  if "$PY" -m pip show "$other" >/dev/null 2>&1; then
    "$PY" -m pip uninstall --quiet -y "$other"
    removed=1
  fi
done
if ! "$PY" -m pip show opencv-contrib-python-headless >/dev/null 2>&1; then
  "$PY" -m pip install --quiet "opencv-contrib-python-headless>=4.8"
elif [ "$removed" = 1 ] || ! "$PY" -c "import cv2; cv2.omnidir" >/dev/null 2>&1; then
  version=$("$PY" -m pip show opencv-contrib-python-headless | sed -n 's/^Version: //p')
  "$PY" -m pip install --quiet --force-reinstall --no-deps "opencv-contrib-python-headless==$version"
fi
"$PY" -c "import cv2; cv2.omnidir" || { echo "error: cv2.omnidir is missing after installing opencv-contrib-python-headless" >&2; exit 1; }
