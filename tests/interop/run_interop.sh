#!/usr/bin/env bash
# The interoperability test (tests/interop/CMakeLists.txt): storey launched from
# bringup.yaml on DDS domain 95, the Cyclone DDS peer (cyclone_peer.c) drives a simulated
# robot into it and checks what storey publishes. Passes when the peer passes, storey
# saw the peer's three writers (its `dds:` debug lines), logged no error, no rejected
# input and no scan without its tf_static mounting, and stopped cleanly on SIGTERM.
#   run_interop.sh STOREY PEER STOREY_QOS_FILE SOURCE_DIR WORK_DIR
set -uo pipefail
if [ $# -ne 5 ]; then
  echo "usage: $0 STOREY PEER STOREY_QOS_FILE SOURCE_DIR WORK_DIR" >&2
  exit 2
fi
storey=$1 peer=$2 qos=$3 here=$4 work=$5
rm -rf "$work"
mkdir -p "$work"
cd "$work"

export ROS_DOMAIN_ID=95                        # and domain_id: 95 in bringup.yaml
export STOREY_QOS_PROFILES=$qos                # storey's profiles, UDP on 127.0.0.1
export STOREY_LOG_LEVEL=debug                  # the dds: lines checked below
export CYCLONEDDS_URI=file://$here/cyclonedds.xml
unset STOREY_SECURITY_DIR

start=$SECONDS
# --duration: a bound should this script be killed before it stops storey.
"$storey" launch "$here/bringup.yaml" --duration 58 >storey.log 2>&1 &
storey_pid=$!
stop_storey() {
  if kill -0 "$storey_pid" 2>/dev/null; then
    kill -TERM "$storey_pid" 2>/dev/null
    for _ in $(seq 150); do
      kill -0 "$storey_pid" 2>/dev/null || break
      sleep 0.1
    done
    kill -KILL "$storey_pid" 2>/dev/null
  fi
}
trap stop_storey EXIT

"$peer" --domain 95 --rate 4 --match-timeout 15 --output-timeout 15 >peer.log 2>&1
peer_status=$?
stop_storey
wait "$storey_pid"
storey_status=$?
trap - EXIT

status=0
cat peer.log
if [ $peer_status -ne 0 ]; then
  echo "FAIL: the Cyclone DDS peer exited with $peer_status"
  status=1
fi
if [ $storey_status -ne 0 ]; then
  echo "FAIL: storey launch exited with $storey_status"
  status=1
fi
for topic in /robot1/scan /robot1/odom tf_static; do
  if ! grep -q "dds: reader on $topic: matched a writer" storey.log; then
    echo "FAIL: storey's reader on $topic matched no writer"
    status=1
  fi
done
if grep -E "^\[error\]|rejected|no tf_static mounting|no odometry near" storey.log; then
  echo "FAIL: storey logged the error(s) above"
  status=1
fi
if [ $status -ne 0 ]; then
  echo "---- storey.log ($work/storey.log)"
  grep -v "^\[debug\] floor_slam" storey.log | tail -n 60
fi
echo "interop: $([ $status -eq 0 ] && echo passed || echo FAILED) in $((SECONDS - start)) s"
exit $status
