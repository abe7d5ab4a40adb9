/*
 * remote_opts.c - the defaults and units of the remote commands' shared
 * options (remote_opts.h).
 */
#include "remote_opts.h"

void remote_opts_init(struct remote_opts *r)
{
    *r = (struct remote_opts){.timeout = REMOTE_TIMEOUT_DEFAULT,
                              .gpu_mib = REMOTE_GPU_MIB_DEFAULT};
}

long remote_timeout_ms(const struct remote_opts *r)
{
    return (long)(r->timeout * 1000);
}

size_t remote_gpu_bytes(const struct remote_opts *r)
{
    return (size_t)(r->gpu_mib * 1048576.0);
}
