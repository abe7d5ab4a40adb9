/*
 * filter_call.c - a request suspended on a job of the filter worker pool
 * (see filter_call.h).
 *
 * The job's arg is the connection itself, so the done() callback, which
 * runs on a pool thread, touches nothing of the request but the call that
 * libmicrohttpd allows from any thread: MHD_resume_connection.
 */
#include "filter_call.h"

static void resume(struct filter_job *j, void *conn)
{
    (void)j;
    MHD_resume_connection(conn);
}

enum MHD_Result filter_call_suspend(struct req *r, struct filter_job *j,
                                    void *async, void (*async_free)(void *))
{
    j->done = resume;
    j->arg = r->conn;
    j->cancel = http_suspend(r, async, async_free); /* before the job can
                                                      resume it */
    filter_jobs_submit(r->srv->filters, j);
    return MHD_YES;
}

void *filter_call_resumed(struct req *r)
{
    void *async = r->async;
    if (async) {
        r->async = NULL;
        r->async_free = NULL;
    }
    return async;
}
