#!/bin/sh
# filter_seccomp.sh - the filter worker's seccomp filter
# (filters/worker_seccomp.c): a worker serving jobs runs under it, normal
# filter jobs still pass, and a worker that tries socket() or execve() in
# a job is killed by SIGSYS, while a call that is only not allowed (an
# open for writing) fails with EPERM and the worker lives on.
#
# Uses tests/gigaview-filter-worker-hooks (make check builds it; it is
# the worker with GV_TEST_HOOKS, never installed): with
# GV_TEST_WORKER_SYSCALL=CALL in its environment (inherited from
# gigaviewd) it makes CALL at the start of each job, after the filter is
# in place.  The worker's state is read from /proc/PID/status (Seccomp:
# 2 is filter mode) and the daemon's log ("worker PID ready").
# Skipped in a build without the GPU, where no EGL context can be made,
# and under valgrind (the daemon is not what is tested).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

hooks=$(dirname "$GIGAVIEW")/tests/gigaview-filter-worker-hooks
if [ ! -x "$hooks" ]; then
    echo "1..0 # SKIP no $hooks (a build without the GPU has no filter workers)"
    exit 0
fi
if under_valgrind; then
    echo "1..0 # SKIP the worker is not run under valgrind"
    exit 0
fi
filter_setup 600x400
cat >"$T/d.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
access_log = off
log_level = info
filter_dir = "$T/stored"
filter_library_dir = "$T/lib"
filter_workers = 1
filter_worker = "$hooks"
drain_timeout = 1
# The jobs that must succeed get no limit a busy machine could meet.
filter_timeout_ms = $((GV_TEST_PATIENCE * 1000))
EOF

# filter: one negate job; status in $code, body in $T/b.
filter() {
    req -X POST --data '{"filter":"negate","region":[0,0,64,48]}' \
        "$(url /v1/images/x/filter)"
}
# worker_pid: the pid of the last worker the daemon reported ready.
worker_pid() {
    sed -n 's/.*slot 0: worker \([0-9]*\) ready.*/\1/p' "$T/daemon.log" | tail -n 1
}

# ---------------------------------------------------------------- no hook
unset GV_TEST_WORKER_SYSCALL
start_daemon "$T/d.conf"
filter
if [ "$code" != 200 ]; then
    skip "the seccomp checks" "no filter jobs here (HTTP $code: $(head -c 200 "$T/b"))"
    stop_daemon
    done_testing
    exit 0
fi
ok "a filter job passes under the seccomp filter (200, $(wc -c <"$T/b" | tr -d ' ') bytes)"
wp=$(worker_pid)
check "the worker ($wp) runs in seccomp filter mode with one filter" \
    sh -c "grep -q '^Seccomp:[[:space:]]*2\$' /proc/$wp/status &&
        grep -q '^Seccomp_filters:[[:space:]]*1\$' /proc/$wp/status"
filter
check "a second job on the same worker passes" sh -c "[ $code = 200 ] && [ '$(worker_pid)' = '$wp' ]"
stop_daemon
check "gigaviewd exits 0" test "$drc" -eq 0

# ---------------------------------------------------------------- hooks
for call in socket execve; do
    GV_TEST_WORKER_SYSCALL=$call
    export GV_TEST_WORKER_SYSCALL
    start_daemon "$T/d.conf"
    filter
    if [ "$code" = 500 ] && grep -q 'the worker process died during the job (killed by signal 31 (SIGSYS))' "$T/b"; then
        ok "a worker that calls $call() in a job is killed by SIGSYS (500)"
    else
        not_ok "a worker that calls $call() is killed by SIGSYS (got $code)" "$(head -c 300 "$T/b")"
    fi
    stop_daemon
done
GV_TEST_WORKER_SYSCALL=open-write
export GV_TEST_WORKER_SYSCALL
start_daemon "$T/d.conf"
filter
wp=$(worker_pid)
filter
if grep -q 'test hook: open-write returned -1 (Operation not permitted)' "$T/b" &&
    [ "$(grep -c 'slot 0: worker [0-9]* ready' "$T/daemon.log")" -eq 1 ] &&
    grep -q '^Seccomp:[[:space:]]*2$' "/proc/$wp/status" 2>/dev/null; then
    ok "an open for writing fails with EPERM and the worker ($wp) lives on: two such jobs, one worker (HTTP $code: the job failed)"
else
    not_ok "an open for writing fails with EPERM (HTTP $code, worker $wp)" "$(head -c 300 "$T/b")"
fi
stop_daemon
unset GV_TEST_WORKER_SYSCALL
done_testing
