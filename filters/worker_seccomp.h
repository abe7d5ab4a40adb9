/*
 * worker_seccomp.h - the system call filter of gigaview-filter-worker
 * (docs/FILTERS.md section 9).
 *
 * Installed once the EGL context is open and before the first byte of a
 * job is read, on every thread of the process (Mesa's are running by
 * then).  From then on the worker may make only the calls that serving
 * jobs on Mesa takes: the socket it was given, memory, threads, time,
 * read-only opens (Mesa's shader cache) and the like.  A call that no
 * job needs but an attacker would (a new socket, a program, a process,
 * ptrace, mounts, kernel modules, BPF ...) kills the process with
 * SIGSYS; anything else not allowed fails with EPERM, as under the
 * systemd unit's SystemCallFilter, so that a probe of an unlisted call
 * stays survivable.
 */
#ifndef GV_WORKER_SECCOMP_H
#define GV_WORKER_SECCOMP_H

#include "base/error.h"

/* Install the filter on all threads of the calling process.  ioctl: allow
 * ioctl(2) too (a hardware GPU driver needs it; llvmpipe does not).
 * Sets no_new_privs.  Returns 0, or -1 with *err when the kernel refuses
 * it or the architecture has no filter here (the worker then refuses to
 * serve). */
int gv_worker_seccomp(int ioctl, struct gv_error *err);

#endif
