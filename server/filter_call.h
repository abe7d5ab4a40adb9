/*
 * filter_call.h - a request suspended on a job of the filter worker pool
 * (filter_jobs.h), for the routes that hand work to the workers (filters,
 * mesh simplification).
 *
 * A route queues its job with filter_call_suspend and returns; the pool's
 * done() callback resumes the connection, and the handler, called again,
 * takes its state back with filter_call_resumed and answers.  Called on
 * the HTTP thread that runs the handler.
 */
#ifndef GV_SERVER_FILTER_CALL_H
#define GV_SERVER_FILTER_CALL_H

#include "filter_jobs.h"
#include "http.h"

/*
 * Queue j (under a reservation the caller holds) on r's server's pool and
 * suspend r's connection until j is done: j->done, j->arg and j->cancel
 * are set here (done() resumes the connection).  `async` (the caller's
 * state, which owns j) and async_free are kept as http_suspend keeps them.
 * Returns MHD_YES.
 */
enum MHD_Result filter_call_suspend(struct req *r, struct filter_job *j,
                                    void *async, void (*async_free)(void *));

/* The state r was suspended with, now the caller's (r no longer frees it),
 * or NULL on the handler's first call. */
void *filter_call_resumed(struct req *r);

#endif
