#!/usr/bin/env bash
# Installs the Debian packages the project needs: povray (the POV-Ray renderer) and
# libllvm19 (for Mitsuba's llvm variants). As root or with passwordless sudo it installs
# them; otherwise it prints the command to run and goes on with what is available.
set -u
pkgs=()
command -v povray >/dev/null 2>&1 || pkgs+=(povray)
# either place will do (one ls of both fails when one of them is absent: it reinstalled every time)
if ! ls /usr/lib/*/libLLVM-19*.so* >/dev/null 2>&1 && ! ls /usr/lib/llvm-19/lib/libLLVM*.so* >/dev/null 2>&1; then
  pkgs+=(libllvm19)
fi
[ ${#pkgs[@]} -eq 0 ] && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
  echo "note: missing ${pkgs[*]} and no apt-get here; install them with your package manager." >&2
  exit 0
fi
if [ "$(id -u)" -eq 0 ]; then
  SUDO=""
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  SUDO="sudo -n"
else
  echo "note: missing Debian packages ${pkgs[*]}; run:  sudo apt-get update && sudo apt-get install -y ${pkgs[*]}" >&2
  exit 0
fi
echo "installing Debian packages: ${pkgs[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq >/dev/null && $SUDO apt-get install -y -qq "${pkgs[@]}" >/dev/null \
  || echo "warning: apt-get install ${pkgs[*]} failed; tests that need them will fail" >&2
exit 0
