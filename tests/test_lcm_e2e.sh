#!/bin/sh
# End-to-end tests of the LCM bridge over real UDP multicast, each process separate, inside a
# network namespace of the test's own (loopback only, ttl=0): no packet leaves the machine.
#
# Environment: PGEM, BRIDGE, SEND, DUMP, COMPARE, FRONTEND (paths of the built programs),
# DATASETS (the shared datasets folder; a simulated graph stands in without it), WORK (a
# scratch folder). Exit 0 pass, 1 fail. A machine that cannot run it (no network namespace:
# not root, no unshare or ip; no lcm-logger) fails it, unless PGEM_ALLOW_SKIP=1 says skipping
# is allowed there: then it exits 77, which CTest reports as skipped. CI never sets it, so a
# CI machine missing a tool fails instead of passing a test that did not run.
set -eu

cannot_run() {
    if [ "${PGEM_ALLOW_SKIP:-}" = 1 ]; then
        echo "SKIP: $*"
        exit 77
    fi
    echo "FAIL: $* (PGEM_ALLOW_SKIP=1 skips this test where it cannot run; CI does not set it)"
    exit 1
}

if [ "${PGEM_IN_NETNS:-}" != 1 ]; then
    if ! command -v unshare >/dev/null 2>&1 || ! command -v ip >/dev/null 2>&1; then
        cannot_run "needs unshare(1) and ip(8) for a private network namespace (tools/setup-debian installs them)"
    fi
    if ! unshare -n true 2>/dev/null; then
        cannot_run "cannot create a network namespace here (needs root or CAP_SYS_ADMIN)"
    fi
    if ! command -v lcm-logger >/dev/null 2>&1; then
        cannot_run "needs lcm-logger (Debian's liblcm-bin; tools/setup-debian installs it)"
    fi
    PGEM_IN_NETNS=1 exec unshare -n sh "$0" "$@"
fi

# Inside the namespace: loopback up, multicast routed to it, LCM confined to it.
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
# UDP is lossy when a sender outruns the receiver's socket buffer: ask for a 4 MiB buffer and
# send at 5000 edges/s (the benchmark measures how far above that it stays lossless).
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
RATE=5000

rm -rf "$WORK"
mkdir -p "$WORK"
cd "$WORK"
pids=""
cleanup() {
    for pid in $pids; do kill -9 "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT

fail() {
    echo "FAIL: $*"
    for log in *.log; do
        [ -f "$log" ] && { echo "--- $log (last 15 lines)"; tail -n 15 "$log"; }
    done
    exit 1
}

step() { echo "== $*"; }

# How many times a bridge's log says it listens (0 without the log).
listening() {
    count=$(grep -c 'listening:' "$1" 2>/dev/null || true)
    echo "${count:-0}"
}

# Starts the bridge in the background: start_bridge NAME [bridge options...]; sets $bridge.
start_bridge() {
    name=$1
    shift
    started=$(listening "$name.log")
    "$BRIDGE" --max-poses 20000 "$@" 2>>"$name.log" &
    bridge=$!
    pids="$pids $bridge"
    # Ready once it says it listens (subscribed: a journal, if any, replayed), a new line in
    # the log it appends to; under load (sanitizers, a busy machine) that can take seconds.
    waited=0
    while [ "$(listening "$name.log")" -le "$started" ]; do
        kill -0 "$bridge" 2>/dev/null || fail "$name: the bridge exited at start"
        waited=$((waited + 1))
        [ "$waited" -le 600 ] || fail "$name: the bridge did not start within 60 s"
        sleep 0.1
    done
    sleep 0.2 # let its first status go out
}

stop_bridge() {
    kill -INT "$bridge"
    wait "$bridge" || fail "the bridge did not exit cleanly on SIGINT"
}

# Starts the dump in the background, waiting for the settle solve's graph (the whole graph
# solved from the front-end's estimates once the stream is quiet) with all $edges edges.
start_dump() {
    name=$1
    "$DUMP" -o "$name.g2o" --weights "$name.weights" --status "$name.status.json" \
        --edges "$edges" --settled --timeout 180 --quiet 2>>"$name.dump.log" &
    dump=$!
    pids="$pids $dump"
    sleep 0.3
}

# agree NAME [REFERENCE]: NAME's dumped graph and weights are REFERENCE's (default offline).
agree() {
    name=$1
    reference=${2:-offline}
    "$COMPARE" "$name.g2o" "$reference.g2o" 1e-6 "$name.weights" "$reference.weights" \
        >"$name.compare" ||
        { cat "$name.compare"; fail "$name: the bridge's graph differs from the offline solve"; }
    cat "$name.compare"
}

step "input: M3500 with 100 random false loop closures, and its offline EM solve"
if [ -f "$DATASETS/2d/input_M3500_g2o.g2o" ]; then
    "$PGEM" corrupt "$DATASETS/2d/input_M3500_g2o.g2o" -o input.g2o --policy random \
        --count 100 --seed 1 >/dev/null
else
    echo "(no datasets folder: a simulated 3500-pose Manhattan walk instead)"
    "$PGEM" simulate --world manhattan --poses 3500 --seed 1 -o clean.g2o >/dev/null
    "$PGEM" corrupt clean.g2o -o input.g2o --policy random --count 100 --seed 1 >/dev/null
fi
"$PGEM" optimize input.g2o --robust em --weights offline.weights -o offline.g2o --quiet
edges=$(grep -c '^EDGE' input.g2o)
echo "$edges edges"

step "while the robot moves: live EM passes bring the live map to batch EM's without a pause"
# The stream never pauses long enough for the settle (--idle-solve 60): what the live map
# holds is the per-update gate's work and the live EM passes adopted while the stream went on
# (without them, 20.7 m and 186 true loops rejected on this kind of stream). The graph right
# after the last edge is reported; the one after the last pass (every loop closure judged by
# a pass, no settle) must be batch EM's within 5 % + 5 cm, with as many loops rejected.
if [ -f "$DATASETS/2d/input_M3500_g2o.g2o" ]; then
    "$PGEM" optimize "$DATASETS/2d/input_M3500_g2o.g2o" -o clean_optimum.g2o --quiet
else
    "$PGEM" optimize clean.g2o -o clean_optimum.g2o --quiet
fi
start_bridge moving --idle-solve 60
"$DUMP" -o instant.g2o --weights instant.weights --edges "$edges" --timeout 180 --quiet \
    2>>moving.dump.log &
instant=$!
"$DUMP" -o moving.g2o --weights moving.weights --json moving.json --idle 20 --timeout 300 --quiet \
    2>>moving.dump.log &
dump=$!
pids="$pids $instant $dump"
sleep 0.3
"$SEND" input.g2o --rate 1000 --wait 60 >moving.send.log 2>&1 || fail "moving: not every edge accepted"
wait "$instant" || fail "moving: no graph with every edge dumped"
wait "$dump" || fail "moving: no graph dumped after the last pass"
stop_bridge
# the last pass judged every loop closure (adopted, or agreeing with the live map's verdicts)
loops=$(grep -vc '^#' offline.weights)
grep "live EM pass [0-9]*: EM on" moving.log | tail -n 1 | grep -q "poses and $loops loops" ||
    { grep "live EM pass" moving.log | tail -n 3; fail "moving: no live EM pass over the whole graph"; }
if grep -q "(settle" moving.log; then fail "moving: a settle ran (the stream had no pause)"; fi
ate() { "$PGEM" eval "$1" --reference clean_optimum.g2o --json | sed 's/.*"ate_translation_rmse":\([^,]*\),.*/\1/'; }
rejected() { "$PGEM" eval "$1" --reference clean_optimum.g2o --outliers input.g2o.outliers --weights "$2" --json | sed 's/.*"rejected":\([0-9]*\),.*/\1/'; }
instant_ate=$(ate instant.g2o)
live_ate=$(ate moving.g2o)
batch_ate=$(ate offline.g2o)
echo "ATE against the clean optimum: right after the last edge $instant_ate m ($(rejected instant.g2o instant.weights) loops rejected), after the last pass $live_ate m ($(rejected moving.g2o moving.weights)), batch EM $batch_ate m ($(rejected offline.g2o offline.weights))"
awk -v l="$live_ate" -v b="$batch_ate" 'BEGIN { exit !(l <= 1.05 * b + 0.05) }' ||
    fail "moving: ATE $live_ate m is above batch EM's $batch_ate m x 1.05 + 0.05 m"
[ "$(rejected moving.g2o moving.weights)" = "$(rejected offline.g2o offline.weights)" ] ||
    fail "moving: the loops rejected differ in number from batch EM's"

step "in order: the dumped graph equals the offline result"
start_bridge ordered --journal ordered.journal
start_dump ordered
"$SEND" input.g2o --rate "$RATE" --wait 60 >ordered.send.log 2>&1 || fail "in order: not every edge accepted"
wait "$dump" || fail "in order: no complete graph dumped"
agree ordered
stop_bridge
# The default: an incremental update per pose, none failed (a failure would restart the next
# solve from the front-end's estimates with EM on the whole graph), then the settle solve.
grep -q "(loops, incremental)" ordered.log || fail "in order: no incremental updates logged"
if grep -q "failed" ordered.log; then fail "in order: a solve failed"; fi
grep -q "(settle, restarted" ordered.log || fail "in order: no settle solve logged"

step "shuffled and every message sent twice, whole-graph solves (--full): the same graph"
start_bridge shuffled --full
start_dump shuffled
"$SEND" input.g2o --rate "$RATE" --shuffle 7 --repeat 2 --wait 60 >shuffled.send.log 2>&1 ||
    fail "shuffled: not every edge accepted"
wait "$dump" || fail "shuffled: no complete graph dumped"
agree shuffled
grep -q "\"replays\":[1-9]" shuffled.status.json || fail "shuffled: no replays counted"
stop_bridge

step "SIGKILL halfway, restart on the journal, send the rest: the same graph"
half=$((edges / 2))
start_bridge killed --journal killed.journal
"$SEND" input.g2o --rate "$RATE" --count "$half" --wait 60 >killed.send1.log 2>&1 ||
    fail "killed: first half not accepted"
kill -9 "$bridge"
wait "$bridge" 2>/dev/null || true
start_bridge killed --journal killed.journal
grep -q "records replayed" killed.log || fail "killed: the restarted bridge replayed nothing"
start_dump killed
"$SEND" input.g2o --rate "$RATE" --first "$half" --wait 60 >killed.send2.log 2>&1 ||
    fail "killed: second half not accepted"
wait "$dump" || fail "killed: no complete graph dumped"
agree killed
stop_bridge

if command -v lcm-logger >/dev/null 2>&1; then # (checked before the namespace: always there)
    step "recorded with lcm-logger, read back: a bridge started on the recording has the graph"
    # the front-end's channels only (all the replay reads)
    lcm-logger --force --channel='PGEM_(POSE2|EDGE2|COMMAND)' recorded.lcmlog >logger.log 2>&1 &
    logger=$!
    pids="$pids $logger"
    sleep 0.3
    # Whole-graph solves at most twice a second: the logger's socket gets every message on the
    # group, the bridge's graphs too (a filter on channels acts after the kernel), and the
    # kernel caps its buffer (net.core.rmem_max, often 208 KB). A graph after every update
    # (800 of them, 8 MB/s) overran it on a loaded machine, and poses were lost mid-stream.
    start_bridge live --full --max-rate 2
    # A smaller graph at a gentle rate: lcm-logger keeps LCM's small handler queue and drops
    # messages when a loaded machine delays it (seen at 2000 edges/s beside a sanitizer build).
    "$PGEM" simulate --world manhattan --poses 600 --seed 2 -o small_clean.g2o >/dev/null
    "$PGEM" corrupt small_clean.g2o -o small.g2o --policy random --count 30 --seed 2 >/dev/null
    edges_all=$edges
    edges=$(grep -c '^EDGE' small.g2o)
    start_dump live
    "$SEND" small.g2o --rate 300 --wait 30 >live.send.log 2>&1 ||
        fail "recorded: not every edge accepted"
    wait "$dump" || fail "recorded: no complete live graph"
    # lcm-logger's subscription keeps LCM's default handler queue (30 messages): delayed on a
    # loaded machine it drops a run of them (poses 112-120 once). Sent twice more, as a
    # front-end that must not lose anything resends: the bridge takes the copies as replays,
    # and the recording misses a message only if all three lost it.
    for again in 1 2; do
        "$SEND" small.g2o --rate 300 >"live.resend$again.log" 2>&1 ||
            fail "recorded: resend $again failed"
    done
    stop_bridge
    # Once the stream is quiet the live bridge settles: the whole graph solved from the
    # front-end's estimates, which is the offline solve of the same file.
    "$PGEM" optimize small.g2o --robust em --weights small_offline.weights \
        -o small_offline.g2o --quiet
    "$COMPARE" live.g2o small_offline.g2o 1e-6 live.weights small_offline.weights ||
        fail "recorded: the live bridge's settled graph differs from the offline solve"
    sleep 0.3
    kill -INT "$logger"
    wait "$logger" || true
    start_dump replayed
    start_bridge replayed --journal recorded.lcmlog
    wait "$dump" || fail "recorded: no complete graph from the recorded log"
    grep -q "records replayed" replayed.log || fail "recorded: the log was not replayed"
    grep "records replayed" replayed.log
    # Rebuilt in one go, the graph is the offline solve of the same file.
    "$COMPARE" replayed.g2o small_offline.g2o 1e-6 replayed.weights small_offline.weights ||
        fail "recorded: the graph rebuilt from the log differs from the offline solve"
    stop_bridge
    edges=$edges_all
else
    echo "(lcm-logger not installed: the recording step is not run)"
fi

step "a pause mid-stream: the settle gives way to the rest, which ends at the offline graph"
# A larger graph, so the settle of the first part (EM on everything from the front-end's
# estimates) is still running when the rest starts arriving.
if [ -f "$DATASETS/2d/city10000.g2o" ]; then
    "$PGEM" corrupt "$DATASETS/2d/city10000.g2o" -o pause_input.g2o --policy random --count 100 \
        --seed 1 >/dev/null
else
    echo "(no datasets folder: a simulated 10000-pose Manhattan walk instead)"
    "$PGEM" simulate --world manhattan --poses 10000 --seed 3 -o paused_clean.g2o >/dev/null
    "$PGEM" corrupt paused_clean.g2o -o pause_input.g2o --policy random --count 100 --seed 1 \
        >/dev/null
fi
"$PGEM" optimize pause_input.g2o --robust em --weights paused_offline.weights -o paused_offline.g2o \
    --quiet
edges_all=$edges
edges=$(grep -c '^EDGE' pause_input.g2o)
# three quarters first: the file's odometry comes before its loops, so this part holds most
# loops and its settle takes long enough (about a second) for the rest to arrive during it
half=$((edges * 3 / 4))
start_bridge paused
start_dump paused
"$SEND" pause_input.g2o --rate "$RATE" --count "$half" --wait 60 >paused.send1.log 2>&1 ||
    fail "paused: first part not accepted"
# (counted from here: a load stall mid-stream may have started an earlier one)
settles=$(grep -c "settle: EM on the whole graph" paused.log || true)
waited=0
until [ "$(grep -c "settle: EM on the whole graph" paused.log || true)" -gt "$settles" ]; do
    sleep 0.05
    waited=$((waited + 1))
    [ "$waited" -lt 600 ] || fail "paused: no settle started within 30 s of the pause"
done
"$SEND" pause_input.g2o --rate "$RATE" --first "$half" --wait 180 >paused.send2.log 2>&1 ||
    fail "paused: the rest not accepted"
wait "$dump" || fail "paused: no complete graph dumped"
agree paused paused_offline
stop_bridge
grep "settle gave way" paused.log || fail "paused: the settle did not give way to the rest"
if grep -q "failed" paused.log; then fail "paused: a solve failed"; fi
edges=$edges_all

step "only false loop closures: the published graph and the status say all were rejected"
"$PGEM" simulate --world manhattan --poses 400 --seed 3 -o chain_src.g2o >/dev/null
# the walk's odometry alone (consecutive ids), then 20 false loop closures
awk '$1 != "EDGE_SE2" || $3 - $2 == 1 || $2 - $3 == 1' chain_src.g2o >chain.g2o
"$PGEM" corrupt chain.g2o -o falsely.g2o --policy random --count 20 --seed 3 >/dev/null
edges_all=$edges
edges=$(grep -c '^EDGE' falsely.g2o)
start_bridge falsely
"$DUMP" -o falsely.g2o.out --json falsely.json --edges "$edges" --settled --timeout 120 \
    --quiet 2>>falsely.dump.log &
dump=$!
pids="$pids $dump"
sleep 0.3
"$SEND" falsely.g2o --rate "$RATE" --wait 60 >falsely.send.log 2>&1 ||
    fail "false loops: not every edge accepted"
wait "$dump" || fail "false loops: no complete graph dumped"
grep -q '"message":"warning: all 20 loop closures rejected' falsely.json ||
    { cat falsely.json; fail "false loops: the graph's stats do not say all were rejected"; }
grep -q "warning: all 20 loop closures rejected" falsely.log ||
    { cat falsely.log; fail "false loops: the bridge's log does not say all were rejected"; }
stop_bridge
edges=$edges_all

if [ -n "${FRONTEND:-}" ]; then
    step "the example front-end: its false loop closure pruned, its true ones kept"
    start_bridge example
    "$FRONTEND" 20 >example.out 2>&1 || { cat example.out; fail "example front-end"; }
    cat example.out
    stop_bridge
else
    echo "(examples not built: the example front-end is not run)"
fi

echo "PASS"
