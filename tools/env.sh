# Source me (bash):  source tools/env.sh
# Puts the fishtail workspace on this shell's environment after tools/bootstrap.sh (make setup):
# - activates .venv (ROS 2 Jazzy wheels, colcon, tools), sources .venv/interfaces (tf2_msgs, which
#   the wheels lack, when make setup built it) as an underlay, then install/setup.bash;
# - AMENT_PREFIX_PATH: the install prefixes first, then the venv prefix (the wheels never set it,
#   and install/setup.bash does not add the venv), so the ament index finds every package;
# - PATH: install/<pkg>/lib/<pkg> for each package, appended, so executables such as
#   `fishtail-kinematics` are callable directly (`ros2 run <pkg> <exe>` resolves the same files).
#   Appended, not prepended: generic names there (`node`, `driver`, `monitor`) must not shadow
#   system commands such as Node.js's `node`; use the full path or `ros2 run` for those;
# - LD_LIBRARY_PATH: the wheels' library dirs, and _ROS_WHEELS_BOOTSTRAP_COMPLETE unset.
#   The wheels' .pth hook re-executes each Python once with LD_LIBRARY_PATH set and the guard
#   variable set; a child that inherited the guard without the library path fails to import
#   rclpy (librcl_action.so). With the path exported here and the guard unset, any process
#   started from this shell, and its children, find the libraries. (A child given a hand-built
#   environment must get LD_LIBRARY_PATH too, or no guard: pass os.environ on.)
# - the upstream ROS 2 tools (`ros2`, `ros2 launch`) from .venv/ros2-tools, if make setup
#   installed them (it does when ../shared/upstream or FISHTAIL_ROS2_UPSTREAM is there);
# - ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_LOG_DIR=<ws>/log/ros, unless already set.
# Safe to source more than once; returns non-zero if the workspace is not set up.

_ft_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
_ft_venv=$_ft_root/.venv

# _ft_append VAR DIR: put DIR last on the colon list VAR unless it is already there. Also drops
# empty entries (colcon's setup scripts leave a trailing ':', which means "the current directory").
_ft_append() {
  local var=$1 dir=$2 cur
  cur=":${!var:-}:"
  while [[ $cur == *::* ]]; do cur=${cur//::/:}; done
  case $cur in
    *":$dir:"*) ;;
    *) cur=$cur$dir: ;;
  esac
  cur=${cur#:}
  export "$var=${cur%:}"
}

_ft_main() {
  if [ ! -x "$_ft_venv/bin/python" ]; then
    echo "env.sh: $_ft_venv is missing: run 'make setup' (tools/bootstrap.sh) first" >&2
    return 1
  fi
  # activate and colcon's setup scripts are not written for `set -u` callers.
  local had_u=0
  case $- in *u*) had_u=1; set +u ;; esac

  # shellcheck disable=SC1091
  VIRTUAL_ENV_DISABLE_PROMPT=${VIRTUAL_ENV_DISABLE_PROMPT:-1} source "$_ft_venv/bin/activate"
  # The venv's own tf2_msgs (tools/interfaces), before the workspace so the workspace overlays it.
  if [ -f "$_ft_venv/interfaces/local_setup.bash" ]; then
    # shellcheck disable=SC1091
    source "$_ft_venv/interfaces/local_setup.bash"
  fi
  if [ -f "$_ft_root/install/setup.bash" ]; then
    # shellcheck disable=SC1091
    source "$_ft_root/install/setup.bash"
  else
    echo "env.sh: $_ft_root/install/setup.bash is missing: run 'make setup' first" >&2
  fi
  # The upstream ROS 2 tools (ros2, ros2 launch), when make setup installed them.
  if [ -f "$_ft_venv/ros2-tools/setup.bash" ]; then
    # shellcheck disable=SC1091
    source "$_ft_venv/ros2-tools/setup.bash"
  fi
  if ((had_u)); then set -u; fi

  # Underlay (venv) after the overlay (install prefixes that setup.bash put on the path).
  _ft_append AMENT_PREFIX_PATH "$_ft_venv"

  local d pkg
  for d in "$_ft_root"/install/*/lib/*/; do
    d=${d%/}
    pkg=${d##*/}
    if [ "$d" = "$_ft_root/install/$pkg/lib/$pkg" ]; then _ft_append PATH "$d"; fi
  done

  for d in "$_ft_venv"/lib/python3.*/site-packages/ros_*.libs; do
    if [ -d "$d" ]; then _ft_append LD_LIBRARY_PATH "$d"; fi
  done
  _ft_append LD_LIBRARY_PATH "$_ft_venv/lib"
  unset _ROS_WHEELS_BOOTSTRAP_COMPLETE

  export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
  export ROS_LOG_DIR=${ROS_LOG_DIR:-$_ft_root/log/ros}
  mkdir -p "$ROS_LOG_DIR"
  export FISHTAIL_ROOT=$_ft_root
}

_ft_main
_ft_rc=$?
unset -f _ft_main _ft_append
unset _ft_root _ft_venv
return "$_ft_rc" 2>/dev/null || exit "$_ft_rc"
