#!/usr/bin/env bash
# Set up the fishtail workspace from a fresh clone: .venv with the pinned ROS 2 Jazzy wheels, the
# wheel CMake path fix, tf2_msgs (which the wheels lack) into .venv/interfaces,
# `colcon build --symlink-install`, and the swimming simulator's numba loop and the synthesis' cycle
# kernel compiled into their caches (python -m fishtail_plant.compiled), so that no later run
# waits for the compiler. Idempotent; a second run with nothing changed takes about a second
# (stamps keyed on hashes of what each step depends on).
#
# Usage: tools/bootstrap.sh [--force-build]
#   --force-build   run colcon build even if the sources' build stamp is current
# Environment: FISHTAIL_PYTHON  interpreter to create .venv with (must be CPython 3.11)
#              FISHTAIL_ROS2_UPSTREAM  folder with install-ros2-tools.sh and the pinned upstream
#                                      ROS 2 tool sources (default ../shared/upstream); installed
#                                      into .venv/ros2-tools when present
#
# Output is one line per step with its elapsed time; a failing step prints the tail of its log.
# Logs: log/bootstrap/<step>.log (colcon's own logs: log/latest_build, log/interfaces/latest_build).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
VENV=$ROOT/.venv
STAMPS=$VENV/.fishtail-stamps          # dies with the venv, so rm -rf .venv resets everything
BUILD_STAMP=$ROOT/install/.fishtail-build-stamp
LOG_DIR=$ROOT/log/bootstrap

force_build=0
for arg in "$@"; do
  case $arg in
    --force-build) force_build=1 ;;
    -h|--help) sed -n '2,17p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bootstrap: unknown argument: $arg" >&2; exit 2 ;;
  esac
done

# A parent Python process of another venv may have left the ros-wheels-bootstrapper guard set
# with its own LD_LIBRARY_PATH: let this venv's interpreters compute their own.
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE
export PIP_NO_INPUT=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_PROGRESS_BAR=off

mkdir -p "$LOG_DIR"
exec 9>"$LOG_DIR/.lock"
if ! flock -n 9; then
  echo "bootstrap: waiting for another bootstrap of this workspace to finish" >&2
  flock 9
fi

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }
T_START=$(now)

# step NAME CMD... : run CMD with its output in log/bootstrap/NAME.log; report time or failure.
step() {
  local name=$1 t0 rc=0
  shift
  t0=$(now)
  "$@" >"$LOG_DIR/$name.log" 2>&1 || rc=$?
  if ((rc != 0)); then
    echo "bootstrap: $name FAILED (exit $rc) after $(elapsed "$t0") s; last lines of" \
      "log/bootstrap/$name.log:" >&2
    tail -n 80 "$LOG_DIR/$name.log" >&2
    local full=
    case $name in
      colcon) full='log/latest_build/<package>/stdout_stderr.log' ;;
      tf2_msgs) full=log/interfaces/latest_build/tf2_msgs/stdout_stderr.log ;;
    esac
    if [ -n "$full" ]; then echo "bootstrap: full package output: $full" >&2; fi
    exit "$rc"
  fi
  printf 'bootstrap: %-10s %6s s\n' "$name" "$(elapsed "$t0")"
}
skip() { printf 'bootstrap: %-10s %8s\n' "$1" "${2:-current}"; }

hash_of() { cat "$@" | sha256sum | cut -c1-32; }

# --- 1. venv ------------------------------------------------------------------------------------
venv_ok() {
  [ -x "$VENV/bin/python" ] &&
    "$VENV/bin/python" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null
}

find_python() {
  local c
  for c in ${FISHTAIL_PYTHON:-} python3.11 python3; do
    if command -v "$c" >/dev/null 2>&1 &&
      "$c" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
      command -v "$c"
      return 0
    fi
  done
  echo "bootstrap: no CPython 3.11 found (python3.11, python3); the ROS 2 Jazzy wheels are" \
    "cp311-only. Set FISHTAIL_PYTHON=/path/to/python3.11." >&2
  return 1
}

# (steps run under `||`, where set -e is off: chain with &&)
make_venv() {
  rm -rf "$VENV" &&
    "$1" -m venv "$VENV" &&
    "$VENV/bin/python" -m pip install --upgrade pip
}

if venv_ok; then
  skip venv
else
  [ -e "$VENV" ] && echo "bootstrap: .venv is unusable (moved, or not Python 3.11); recreating" >&2
  py=$(find_python)
  step venv make_venv "$py"
fi
# colcon must not crawl the venv (share/*/package.xml of every ROS wheel lives there).
touch "$VENV/COLCON_IGNORE"
mkdir -p "$STAMPS"

# --- 2. pinned wheels, then the CMake path fix (every install restores the wheels' files) -------
pip_key=$(hash_of requirements.txt tools/fix_wheel_cmake_paths.py)
if [ "$(cat "$STAMPS/pip" 2>/dev/null)" = "$pip_key" ]; then
  skip pip
  skip cmakefix
else
  rm -f "$STAMPS/pip" "$BUILD_STAMP"
  step pip "$VENV/bin/python" -m pip install -r requirements.txt
  step cmakefix "$VENV/bin/python" tools/fix_wheel_cmake_paths.py
  echo "$pip_key" >"$STAMPS/pip"
fi

# --- 3. upstream ROS 2 tools (ros2 CLI, ros2 launch), when their pinned sources are at hand -----
# They are not published as wheels; a system ROS 2 ships them. FISHTAIL_ROS2_UPSTREAM names the
# folder that holds install-ros2-tools.sh and the archives (default: ../shared/upstream beside the
# workspace). The script keeps its own stamp, so a second run is a hash of the archives.
UPSTREAM=${FISHTAIL_ROS2_UPSTREAM:-$ROOT/../shared/upstream}
if [ -f "$UPSTREAM/install-ros2-tools.sh" ]; then
  step ros2tools bash "$UPSTREAM/install-ros2-tools.sh" "$VENV" "$VENV/ros2-tools"
else
  skip ros2tools "skipped: no $UPSTREAM/install-ros2-tools.sh (set FISHTAIL_ROS2_UPSTREAM)"
fi

# --- 4. tf2_msgs, which the wheels lack -----------------------------------------------------------
# The simulator publishes /tf and /tf_static only where tf2_msgs imports. tools/interfaces/tf2_msgs
# has its TFMessage with the real definition (so the real type hash, which RViz on a ROS machine
# needs); it goes into its own prefix, which tools/env.sh sources as an underlay. A tf2_msgs that
# the user put into the venv itself wins: ours is then neither built nor kept.
TF2_SRC=tools/interfaces/tf2_msgs
TF2_PREFIX=$VENV/interfaces

venv_has_tf2_msgs() {
  # Without PYTHONPATH, which a shell that sourced env.sh points at our own prefix.
  env -u PYTHONPATH "$VENV/bin/python" -c \
    'import importlib.util, sys; sys.exit(importlib.util.find_spec("tf2_msgs") is None)' 2>/dev/null
}

files_key() {
  find "$@" -type f 2>/dev/null | LC_ALL=C sort |
    while IFS= read -r f; do echo "$f $(sha256sum <"$f" | cut -c1-32)"; done |
    sha256sum | cut -c1-32
}

# A subshell: its environment must not reach the workspace build.
interfaces_build() (
  export VIRTUAL_ENV=$VENV
  export PATH=$VENV/bin:$PATH
  export AMENT_PREFIX_PATH=$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}
  # Its setup.bash must chain no other prefix (env.sh layers the prefixes itself).
  unset COLCON_PREFIX_PATH
  rm -rf "$TF2_PREFIX" build/interfaces &&
    colcon --log-base log/interfaces build --base-paths "$TF2_SRC" \
      --build-base build/interfaces --install-base "$TF2_PREFIX" \
      --event-handlers console_direct- \
      --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF
)

tf2_key=$( { echo "$pip_key"; files_key "$TF2_SRC"; } | sha256sum | cut -c1-32)
if venv_has_tf2_msgs; then
  rm -rf "$TF2_PREFIX" "$STAMPS/tf2_msgs"
  skip tf2_msgs "skipped: the venv has its own"
elif [ -f "$TF2_PREFIX/local_setup.bash" ] &&
  [ "$(cat "$STAMPS/tf2_msgs" 2>/dev/null)" = "$tf2_key" ]; then
  skip tf2_msgs
else
  rm -f "$STAMPS/tf2_msgs"
  step tf2_msgs interfaces_build
  echo "$tf2_key" >"$STAMPS/tf2_msgs"
fi

# --- 5. colcon build -----------------------------------------------------------------------------
# The build stamp hashes what a --symlink-install build depends on: the wheel set, and the content
# of every file under src/ except Python files, which --symlink-install links (the package
# directories themselves are symlinked, so new modules need no build either). Of those, setup.py
# counts by content and __init__.py by path (a new top-level package needs a build).
build_key() {
  {
    echo "$pip_key"
    find src -type f ! -path '*/__pycache__/*' ! -name '*.pyc' 2>/dev/null | LC_ALL=C sort |
      while IFS= read -r f; do
        case $f in
          */setup.py) echo "$f $(sha256sum <"$f" | cut -c1-32)" ;;
          */__init__.py) echo "$f" ;;  # a new top-level Python package needs a build
          *.py) ;;                     # modules and tests: symlinked, never need one
          *) echo "$f $(sha256sum <"$f" | cut -c1-32)" ;;
        esac
      done
  } | sha256sum | cut -c1-32
}

colcon_build() {
  export VIRTUAL_ENV=$VENV
  export PATH=$VENV/bin:$PATH
  # The wheels never set AMENT_PREFIX_PATH; without the venv on it, rosidl's find_package()
  # fails (No 'rosidl_typesupport_c' found).
  export AMENT_PREFIX_PATH=$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}
  # --base-paths src: colcon must not crawl .venv, build/ or install/.
  colcon build --symlink-install --base-paths src \
    --event-handlers console_direct- \
    --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF
}

key=$(build_key)
if ((force_build == 0)) && [ -f install/setup.bash ] && [ -d build ] &&
  [ "$(cat "$BUILD_STAMP" 2>/dev/null)" = "$key" ]; then
  skip colcon
else
  rm -f "$BUILD_STAMP"
  step colcon colcon_build
  echo "$key" >"$BUILD_STAMP"
fi

# --- 6. the swimming integrator, compiled once ------------------------------------------------
# The simulator's RK4 loop is compiled by numba (10-20 s on 2 cores) and cached on disk, beside
# fused.py in src/ (the symlinked build/ path leads there) or under NUMBA_CACHE_DIR; the same run
# compiles the engine's batch pass (drive_pass_numba.py) and the synthesis' cycle kernels
# (cycle_kernel.py, and loop_kernel.py for mechanism 2, which compiles cycle_kernel's shared
# pieces and the engine's loop_pose.py into its own). Done here, so that the first `make run`
# swims at once instead of compiling while the motor turns. numba reloads the caches while their sources (those files and the
# formulas they compile) keep their size and mtime, so the stamp hashes those, the cache
# location and the caches' index files (a deleted cache is compiled again).
FUSED=src/fishtail_plant/fishtail_plant/fish/fused.py
COMPILED_SOURCES=(
  "$FUSED"
  src/fishtail_plant/fishtail_plant/fish/cycle_kernel.py
  src/fishtail_plant/fishtail_plant/fish/loop_kernel.py
  src/fishtail_plant/fishtail_plant/fish/formulas.py
  src/fishtail_plant/fishtail_plant/fish/figures.py
  src/fishtail_plant/fishtail_plant/fish/tail_drive.py
  src/fishtail_kinematics/fishtail_kinematics/engine/oscillatory_tail.py
  src/fishtail_kinematics/fishtail_kinematics/engine/loop_pose.py
  src/fishtail_kinematics/fishtail_kinematics/engine/drive_pass_numba.py
)
integrator_key() {
  {
    echo "$key ${NUMBA_CACHE_DIR:-}"
    stat -c '%n %s %Y' "${COMPILED_SOURCES[@]}"
    find "${NUMBA_CACHE_DIR:-$(dirname "$FUSED")/__pycache__}" \
      "${NUMBA_CACHE_DIR:-src/fishtail_kinematics/fishtail_kinematics/engine/__pycache__}" \
      \( -name 'fused._rk4_steps-*.nbi' -o -name 'cycle_kernel._held_cycles-*.nbi' \
      -o -name 'loop_kernel._follow_all-*.nbi' -o -name 'loop_kernel._held_loop_cycles-*.nbi' \
      -o -name 'drive_pass_numba._rates-*.nbi' \) \
      -exec stat -c '%n %s %Y' {} + 2>/dev/null | LC_ALL=C sort
  } | sha256sum | cut -c1-32
}

# A subshell: the workspace environment must not leak into the rest of this script.
integrator_compile() (
  # shellcheck disable=SC1091
  source "$ROOT/tools/env.sh" >/dev/null && python -m fishtail_plant.compiled
)

if [ "$(cat "$STAMPS/integrator" 2>/dev/null)" = "$(integrator_key)" ]; then
  skip integrator
else
  rm -f "$STAMPS/integrator"
  step integrator integrator_compile
  printf 'bootstrap: %-10s %s\n' '' "$(tail -n 1 "$LOG_DIR/integrator.log")"
  integrator_key >"$STAMPS/integrator"
fi

printf 'bootstrap: %-10s %6s s   (source tools/env.sh to use the workspace)\n' total \
  "$(elapsed "$T_START")"
