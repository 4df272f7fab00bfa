#!/usr/bin/env bash
# One entry point for a fresh Debian/Ubuntu machine: installs what objrec needs (once; a second run is
# fast), then runs the demo or the test suite.
#   bash scripts/objrec.sh demo   # set up, then detect objects in the built-in demo scene
#   bash scripts/objrec.sh test   # set up, then ruff check and the whole test suite (doc snippets included)
#   bash scripts/objrec.sh setup  # set up only
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=${OBJREC_VENV:-$ROOT/.venv}
PY=${PYTHON:-python3}

say() { printf 'objrec: %s\n' "$*" >&2; }

# System libraries: Open3D needs libusb; Qt needs GL/EGL/xkbcommon/fontconfig even offscreen and the xcb
# libraries on a real display; Xvfb gives tests and screenshots a display. Installed only when one is missing.
APT_PACKAGES=(python3 python3-venv python3-pip libusb-1.0-0 libgl1 libegl1 libxkbcommon0 libfontconfig1
              libglib2.0-0 libdbus-1-3 xvfb
              libxcb-cursor0 libxcb-icccm4 libxcb-image0 libxcb-keysyms1 libxcb-randr0 libxcb-render-util0
              libxcb-shape0 libxcb-xkb1 libxkbcommon-x11-0)
install_system_packages() {
  command -v dpkg-query >/dev/null 2>&1 || { say "not a Debian/Ubuntu system: install ${APT_PACKAGES[*]} yourself"; return 0; }
  local missing=() p
  for p in "${APT_PACKAGES[@]}"; do
    installed "$p" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null 2>&1 || { say "need root or sudo to install: ${missing[*]}"; exit 1; }
    sudo="sudo"
  fi
  say "installing system packages: ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  # Newer releases renamed some libraries (libglib2.0-0 -> libglib2.0-0t64): take what this one has.
  local resolved=()
  for p in "${missing[@]}"; do
    if apt-cache show "${p}t64" >/dev/null 2>&1; then resolved+=("${p}t64"); else resolved+=("$p"); fi
  done
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${resolved[@]}" >/dev/null
}

# Test-only: Debian's ROS 1 (a real master, rospy nodes, rosbag) for the live-topic tests, which talk to them
# over loopback. objrec itself never needs ROS installed. Where a package is missing (not Debian 12, or no
# network), the tests that need it skip and say so; nothing else depends on it.
ROS1_TEST_PACKAGES=(python3-rospy python3-rosbag python3-rosmaster python3-rostopic python3-genpy
                    python3-std-msgs python3-sensor-msgs python3-geometry-msgs python3-nav-msgs
                    python3-actionlib-msgs python3-move-base-msgs)
install_ros1_test_packages() {
  command -v dpkg-query >/dev/null 2>&1 || return 0
  local missing=() p
  for p in "${ROS1_TEST_PACKAGES[@]}"; do
    installed "$p" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null 2>&1 || { say "no root or sudo: the ROS 1 live tests will skip"; return 0; }
    sudo="sudo"
  fi
  say "installing Debian's ROS 1 for the live tests: ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq || true
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    >/dev/null 2>&1 || say "Debian's ROS 1 packages could not be installed here: the ROS 1 live tests will skip"
}

# Installed under its name or its t64-renamed successor.
installed() {
  local name
  for name in "$1" "${1}t64"; do
    dpkg-query -W -f='${Status}' "$name" 2>/dev/null | grep -q "install ok installed" && return 0
  done
  return 1
}

install_python_packages() {
  # A venv left half-made (no pip: ensurepip missing, or an interrupted run) is made again.
  if ! "$VENV/bin/python" -m pip --version >/dev/null 2>&1; then
    say "creating the virtual environment in $VENV"
    "$PY" -m venv --clear "$VENV"
  fi
  local stamp="$VENV/.objrec-setup"
  local want
  want=$(sha256sum pyproject.toml | cut -d' ' -f1)
  if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && "$VENV/bin/python" -c "import objrec_core" 2>/dev/null; then
    return 0
  fi
  say "installing objrec and its Python dependencies (first run: a few minutes)"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  "$VENV/bin/python" -m pip install -q -e ".[dev]"
  echo "$want" > "$stamp"
}

setup() {
  install_system_packages
  install_python_packages
}

case "${1:-}" in
  setup)
    setup ;;
  demo)
    setup
    shift
    exec "$VENV/bin/objrec-detect" params/hsv_demo.yaml --source demo --max-frames 100 "$@" ;;
  test)
    setup
    install_ros1_test_packages
    shift
    export QT_QPA_PLATFORM=offscreen
    # Lint first: a finding fails the command before the (long) suite runs, in CI as on a developer's machine.
    say "ruff check ."
    "$VENV/bin/ruff" check . || { say "ruff check found problems (above): fix them, then run again"; exit 1; }
    exec "$VENV/bin/python" -m pytest "$@" ;;
  *)
    echo "usage: bash scripts/objrec.sh demo|test|setup" >&2
    exit 2 ;;
esac
