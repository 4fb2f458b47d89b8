#!/usr/bin/env bash
# Build the package with colcon in a throw-away workspace, check the install layout that
# `ros2 run` and `ros2 launch` expect, and start one installed node executable until it says it
# is up, then stop it with SIGINT and require a clean exit.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
workspace="$(mktemp -d)"
trap 'rm -rf "$workspace"' EXIT
mkdir -p "$workspace/src/robot_wear_monitor"
# the tracked files only (no build/, install/, caches or outputs of a local run)
(cd "$repo" && git ls-files -z | xargs -0 cp --parents -t "$workspace/src/robot_wear_monitor/")
(cd "$workspace" && colcon build --event-handlers console_cohesion- > build.log 2>&1) || {
  cat "$workspace/build.log" >&2; echo "colcon_check: colcon build failed" >&2; exit 1; }
prefix="$workspace/install/robot_wear_monitor"
missing=0
for path in lib/robot_wear_monitor/friction_experiment_node \
            lib/robot_wear_monitor/wear_estimator_node \
            lib/robot_wear_monitor/friction_experiment_runner \
            lib/robot_wear_monitor/robot-wear-monitor \
            share/robot_wear_monitor/package.xml \
            share/robot_wear_monitor/launch/wear_monitor_launch.py \
            share/robot_wear_monitor/config/wear_monitor.yaml \
            share/robot_wear_monitor/config/irb6620_joint2.yaml \
            share/ament_index/resource_index/packages/robot_wear_monitor; do
  if [ ! -e "$prefix/$path" ]; then echo "colcon_check: missing $path" >&2; missing=1; fi
done
[ "$missing" = 0 ] || exit 1
echo "colcon_check: install layout ok ($prefix)"
site="$(ls -d "$prefix"/lib/python3*/site-packages)"
log="$workspace/node.log"
ROS_DOMAIN_ID=$(( 150 + $$ % 50 )) ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST PYTHONPATH="$site" \
  python3 "$prefix/lib/robot_wear_monitor/wear_estimator_node" \
  --ros-args -p "history_file:=$workspace/history.sqlite3" > "$log" 2>&1 &
node=$!
for _ in $(seq 1 600); do
  if grep -q 'history .*estimates restored' "$log"; then break; fi
  if ! kill -0 "$node" 2>/dev/null; then break; fi
  sleep 0.1
done
if ! grep -q 'history .*estimates restored' "$log"; then
  kill -9 "$node" 2>/dev/null || true
  cat "$log" >&2; echo "colcon_check: the installed wear_estimator_node did not start" >&2
  exit 1
fi
kill -INT "$node"
status=0
wait "$node" || status=$?
if [ "$status" != 0 ]; then
  cat "$log" >&2; echo "colcon_check: wear_estimator_node exited $status on SIGINT" >&2
  exit 1
fi
echo "colcon_check: the installed wear_estimator_node started and stopped cleanly"
