#!/usr/bin/env bash
# What the tests need beyond the Rust toolchain, installed if missing (run by `cargo xtask
# test`, hence by .ci/run). Idempotent and quick when everything is there.
# - system libraries the editor loads at run time (X11/xcb/xkbcommon/GL/Vulkan), Mesa's
#   software Vulkan (lavapipe, for the editor screenshots) and OpenGL (llvmpipe), and Xvfb
#   (the CLAP host test opens the editor in a real X11 window);
# - a Python virtual environment, target/test-venv, with pedalboard (JUCE's VST3 host) and
#   numpy, for tests/hosts/pedalboard_host.py, and scipy for the FEM references
#   (presets/fem/tests/reference/axisymmetric.py);
# - Ardour 7 for the second VST3 host test (tests/hosts/ardour_host.sh).
# Without root, missing system packages are named in one line and the script fails.
set -euo pipefail
cd "$(dirname "$0")/.."

pkgs="libx11-6 libx11-xcb1 libxcb1 libxcursor1 libxkbcommon-x11-0 libgl1 libvulkan1 mesa-vulkan-drivers xvfb libgl1-mesa-dri libglx-mesa0"
command -v cc >/dev/null 2>&1 || pkgs="$pkgs build-essential pkg-config"
missing=""
for p in $pkgs; do
  dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
done
if [ -n "$missing" ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup: installing$missing"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null
  else
    echo "setup: the tests need these Debian packages:$missing (install them: sudo apt-get install$missing)" >&2
    exit 1
  fi
fi

# Ardour 7 (Debian's `ardour`: its headless Lua session host ardour7-lua and VST3 scanner) for
# tests/hosts/ardour_host.sh; without its recommended packages (about 50 MB).
if ! dpkg -s ardour 2>/dev/null | grep -q '^Status: install ok installed'; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup: installing ardour"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends ardour >/dev/null \
      || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends ardour >/dev/null; } \
      || echo "setup: warning: ardour could not be installed; the Ardour host test will fail, the others run" >&2
  else
    # Only the Ardour host test needs it: it fails alone, the others run.
    echo "setup: warning: the Ardour host test needs the Debian package ardour (sudo apt-get install --no-install-recommends ardour)" >&2
  fi
fi

venv=target/test-venv
if ! "$venv/bin/python" -c "import pedalboard, numpy" >/dev/null 2>&1; then
  echo "setup: creating $venv with pedalboard and numpy"
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check "pedalboard==0.9.26" "numpy>=1.24,<3"
fi
if ! "$venv/bin/python" -c "import scipy" >/dev/null 2>&1; then
  echo "setup: adding scipy to $venv"
  "$venv/bin/pip" install -q --disable-pip-version-check "scipy>=1.11,<2"
fi
