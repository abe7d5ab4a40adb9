/*
 * job_queue.h - an intrusive FIFO of jobs, shared by the render pool
 * (render_pool.c) and the filter worker pool (filter_jobs.c).
 *
 * A job embeds a struct job_link; the queue links those, so pushing and
 * popping never allocate.  The queue itself holds no lock: its owner
 * guards it with its own mutex, together with its other counters.
 * job_queue_entry turns a link back into the job that embeds it.
 */
#ifndef GV_SERVER_JOB_QUEUE_H
#define GV_SERVER_JOB_QUEUE_H

#include <stddef.h>

struct job_link {
    struct job_link *next;
};

struct job_queue {
    struct job_link *head, *tail;
    int count;                  /* links in the queue */
};

/* The job of type `type` whose member `member` is the link l (l != NULL). */
#define job_queue_entry(l, type, member) \
    ((type *)(void *)((char *)(l) - offsetof(type, member)))

/* Append l at the tail. */
static inline void job_queue_push(struct job_queue *q, struct job_link *l)
{
    l->next = NULL;
    if (q->tail)
        q->tail->next = l;
    else
        q->head = l;
    q->tail = l;
    q->count++;
}

/* Remove and return the head, or NULL when the queue is empty. */
static inline struct job_link *job_queue_pop(struct job_queue *q)
{
    struct job_link *l = q->head;
    if (l) {
        q->head = l->next;
        if (!q->head)
            q->tail = NULL;
        q->count--;
        l->next = NULL;
    }
    return l;
}

/* Empty the queue, returning its links in order (follow ->next). */
static inline struct job_link *job_queue_take_all(struct job_queue *q)
{
    struct job_link *l = q->head;
    q->head = q->tail = NULL;
    q->count = 0;
    return l;
}

#endif
