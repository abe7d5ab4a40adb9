/*
 * worker_seccomp.c - the filter worker's seccomp filter (worker_seccomp.h).
 *
 * A classic BPF program, built here without libseccomp (one fewer
 * dependency, and the program is short enough to read):
 *
 *   1. a foreign architecture (and, on x86-64, the x32 ABI) is killed, so
 *      no call can slip past under another number;
 *   2. the calls in killed[] kill the process (SIGSYS);
 *   3. clone only for a thread (CLONE_THREAD, else killed); clone3 fails
 *      with ENOSYS, on which glibc falls back to clone, whose flags a
 *      filter can read (clone3 keeps them in memory);
 *   4. openat only without write access or creation (Mesa reads its
 *      shader cache; a cache write fails with EPERM and Mesa carries on);
 *   5. the calls in allowed[] (and ioctl when asked) are allowed;
 *   6. anything else fails with EPERM.
 *
 * allowed[] is what `strace -f` shows a worker making once its context is
 * open, over the stock filters on llvmpipe (tests/systemd_unit.sh runs
 * them), plus what glibc and Mesa do on paths a job may take: a thread
 * started late, a larger allocation, an abort().  Every entry is a subset
 * of the systemd unit's SystemCallFilter (conf/gigaviewd.service).
 */
#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <stddef.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <linux/audit.h>
#include <linux/filter.h>
#include <linux/seccomp.h>

#include "worker_seccomp.h"

#if defined(__x86_64__)
#define GV_AUDIT_ARCH AUDIT_ARCH_X86_64
#elif defined(__aarch64__)
#define GV_AUDIT_ARCH AUDIT_ARCH_AARCH64
#endif

#ifdef GV_AUDIT_ARCH

/* Calls that serving jobs never makes and an attacker in the worker
 * would want first: killed. */
static const long killed[] = {
    SYS_socket, SYS_socketpair, SYS_connect, SYS_bind, SYS_listen,
    SYS_accept, SYS_accept4, SYS_execve, SYS_execveat, SYS_ptrace,
    SYS_process_vm_readv, SYS_process_vm_writev, SYS_kill, SYS_unshare,
    SYS_setns, SYS_mount, SYS_umount2, SYS_pivot_root, SYS_chroot,
    SYS_init_module, SYS_finit_module, SYS_delete_module, SYS_kexec_load,
    SYS_reboot, SYS_bpf, SYS_perf_event_open, SYS_userfaultfd, SYS_keyctl,
    SYS_add_key, SYS_request_key, SYS_open_by_handle_at,
    SYS_name_to_handle_at, SYS_personality, SYS_io_uring_setup,
    SYS_io_uring_enter, SYS_io_uring_register,
#ifdef SYS_fork
    SYS_fork,
#endif
#ifdef SYS_vfork
    SYS_vfork,
#endif
#ifdef SYS_kexec_file_load
    SYS_kexec_file_load,
#endif
};

/* Calls a worker makes while it serves jobs. */
static const long allowed[] = {
    /* the job socket and the files Mesa reads */
    SYS_read, SYS_write, SYS_readv, SYS_writev, SYS_pread64, SYS_recvfrom,
    SYS_recvmsg, SYS_sendto, SYS_sendmsg, SYS_close, SYS_lseek, SYS_fstat,
    SYS_newfstatat, SYS_statx, SYS_fcntl, SYS_readlinkat, SYS_faccessat,
    SYS_getdents64, SYS_ppoll,
#ifdef SYS_poll
    SYS_poll,
#endif
#ifdef SYS_access
    SYS_access,
#endif
#ifdef SYS_readlink
    SYS_readlink,
#endif
    /* memory, and the JIT's executable pages */
    SYS_mmap, SYS_munmap, SYS_mprotect, SYS_mremap, SYS_madvise, SYS_brk,
    SYS_membarrier,
    /* threads and their scheduling (Mesa's queues lower their own) */
    SYS_futex, SYS_set_robust_list, SYS_get_robust_list, SYS_rseq,
    SYS_sched_yield, SYS_sched_getaffinity, SYS_sched_setaffinity,
    SYS_sched_setscheduler, SYS_sched_getscheduler, SYS_sched_getparam,
    SYS_setpriority, SYS_getpriority, SYS_set_tid_address, SYS_prctl,
    SYS_prlimit64, SYS_getrlimit,
    /* identity, time and randomness */
    SYS_getpid, SYS_gettid, SYS_getppid, SYS_getuid, SYS_geteuid,
    SYS_getgid, SYS_getegid, SYS_uname, SYS_sysinfo, SYS_getrandom,
    SYS_clock_gettime, SYS_clock_getres, SYS_gettimeofday,
    SYS_clock_nanosleep, SYS_nanosleep,
    /* signals (abort, raise) and the end */
    SYS_rt_sigreturn, SYS_rt_sigprocmask, SYS_rt_sigaction, SYS_sigaltstack,
    SYS_tgkill, SYS_restart_syscall, SYS_exit, SYS_exit_group,
#ifdef SYS_arch_prctl
    SYS_arch_prctl,
#endif
};

#define PROG_MAX 256
#define ARG_LO(i) (offsetof(struct seccomp_data, args) + 8 * (i)) /* little-endian */

struct prog {
    struct sock_filter f[PROG_MAX];
    unsigned short n;
};

static void emit(struct prog *p, struct sock_filter s)
{
    if (p->n < PROG_MAX)
        p->f[p->n] = s;
    p->n++;
}

#define STMT(code, k) emit(p, (struct sock_filter)BPF_STMT(code, k))
#define JUMP(code, k, jt, jf) emit(p, (struct sock_filter)BPF_JUMP(code, k, jt, jf))
#define RET(k) STMT(BPF_RET | BPF_K, k)
#define LOAD(off) STMT(BPF_LD | BPF_W | BPF_ABS, off)
#define IF_NR(nr, skip) JUMP(BPF_JMP | BPF_JEQ | BPF_K, (unsigned)(nr), 0, skip)

static void build(struct prog *p, int ioctl)
{
    LOAD(offsetof(struct seccomp_data, arch));
    JUMP(BPF_JMP | BPF_JEQ | BPF_K, GV_AUDIT_ARCH, 1, 0);
    RET(SECCOMP_RET_KILL_PROCESS);
    LOAD(offsetof(struct seccomp_data, nr));
#ifdef __x86_64__
    JUMP(BPF_JMP | BPF_JGE | BPF_K, 0x40000000u, 0, 1); /* __X32_SYSCALL_BIT */
    RET(SECCOMP_RET_KILL_PROCESS);
#endif
    for (size_t i = 0; i < sizeof killed / sizeof killed[0]; i++) {
        IF_NR(killed[i], 1);
        RET(SECCOMP_RET_KILL_PROCESS);
    }
    IF_NR(SYS_clone, 4);
    LOAD(ARG_LO(0));
    JUMP(BPF_JMP | BPF_JSET | BPF_K, CLONE_THREAD, 0, 1);
    RET(SECCOMP_RET_ALLOW);
    RET(SECCOMP_RET_KILL_PROCESS);
    IF_NR(SYS_clone3, 1);
    RET(SECCOMP_RET_ERRNO | ENOSYS);
    IF_NR(SYS_openat, 4);
    LOAD(ARG_LO(2));
    JUMP(BPF_JMP | BPF_JSET | BPF_K,
         O_WRONLY | O_RDWR | O_CREAT | O_TRUNC | O_APPEND, 1, 0);
    RET(SECCOMP_RET_ALLOW);
    RET(SECCOMP_RET_ERRNO | EPERM);
    if (ioctl) {
        IF_NR(SYS_ioctl, 1);
        RET(SECCOMP_RET_ALLOW);
    }
    for (size_t i = 0; i < sizeof allowed / sizeof allowed[0]; i++) {
        IF_NR(allowed[i], 1);
        RET(SECCOMP_RET_ALLOW);
    }
    RET(SECCOMP_RET_ERRNO | EPERM);
}

int gv_worker_seccomp(int ioctl, struct gv_error *err)
{
    struct prog p = {.n = 0};
    build(&p, ioctl);
    if (p.n > PROG_MAX)
        return gv_fail(err, GV_EIO, "seccomp: program of %u instructions "
                       "(room for %d)", p.n, PROG_MAX);
    struct sock_fprog fp = {.len = p.n, .filter = p.f};
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) < 0)
        return gv_fail(err, GV_EIO, "seccomp: PR_SET_NO_NEW_PRIVS: %s",
                       strerror(errno));
    long rc = syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER,
                      SECCOMP_FILTER_FLAG_TSYNC, &fp);
    if (rc < 0)
        return gv_fail(err, GV_EIO, "seccomp: the kernel refused the filter: %s",
                       strerror(errno));
    if (rc > 0)
        return gv_fail(err, GV_EIO, "seccomp: thread %ld could not take the "
                       "filter", rc);
    return 0;
}

#else /* no filter for this architecture */

int gv_worker_seccomp(int ioctl, struct gv_error *err)
{
    (void)ioctl;
    return gv_fail(err, GV_EIO, "seccomp: no filter for this architecture");
}

#endif
