/*
 * load_client.c - a closed-loop HTTP load generator for bench/load-soak.sh.
 *
 *   load_client BASE-URL CONNECTIONS SECONDS REQUESTS-FILE [INTERVAL]
 *
 * Keeps CONNECTIONS requests in flight on as many keep-alive connections
 * (libcurl multi, HTTP/1.1), each connection taking the next line of
 * REQUESTS-FILE in turn, until SECONDS have passed.  A line is
 *
 *   KIND METHOD PATH [BODY]
 *
 * (BODY, for POST, is the rest of the line, sent as application/json).
 * Every INTERVAL seconds (default 10) it prints one progress line on
 * stderr; at the end, one line per KIND and a total on stdout:
 *
 *   KIND requests ok limited errors p50_ms p99_ms p999_ms max_ms
 *
 * "ok" is a 2xx with a complete body; "limited" is a deliberate refusal
 * by a configured limit (413, 429, or 503 with Retry-After); anything
 * else, a transport error included, is an error, and the first few are
 * printed.  Latency is libcurl's total time of the transfer on its
 * (already open) connection.  Exit status: 0, or 1 when there was any
 * error.  Loopback benchmarking only: no TLS, no redirects.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include <curl/curl.h>

#define MAX_KINDS 16
#define MAX_SHOWN 10   /* errors printed in full */

struct request {
    int kind;
    int post;
    char *url;
    char *body;
};

struct kind {
    char name[32];
    uint64_t n, ok, limited, errors;
    uint32_t *lat_us;          /* one per completed request */
    size_t nlat, cap;
};

struct conn {
    CURL *h;
    const struct request *req;
    struct curl_slist *hdr;
    int retry_after;           /* a Retry-After header was seen */
    uint64_t bytes;
};

static struct kind kinds[MAX_KINDS];
static int nkinds;
static int shown;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int kind_of(const char *name)
{
    for (int i = 0; i < nkinds; i++)
        if (!strcmp(kinds[i].name, name))
            return i;
    if (nkinds == MAX_KINDS) {
        fprintf(stderr, "load_client: more than %d kinds\n", MAX_KINDS);
        exit(2);
    }
    snprintf(kinds[nkinds].name, sizeof kinds[nkinds].name, "%s", name);
    return nkinds++;
}

static struct request *load_requests(const char *base, const char *path,
                                     size_t *count)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        perror(path);
        exit(2);
    }
    size_t n = 0, cap = 0;
    struct request *r = NULL;
    char line[8192];
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = '\0';
        char kind[32], method[8];
        int off = 0;
        if (line[0] == '#' || sscanf(line, "%31s %7s %n", kind, method, &off) != 2)
            continue;
        char *p = line + off, *sp = strchr(p, ' ');
        if (sp)
            *sp++ = '\0';
        if (n == cap) {
            cap = cap ? 2 * cap : 1024;
            r = realloc(r, cap * sizeof *r);
            if (!r)
                exit(2);
        }
        r[n].kind = kind_of(kind);
        r[n].post = !strcmp(method, "POST");
        size_t ul = strlen(base) + strlen(p) + 1;
        r[n].url = malloc(ul);
        if (!r[n].url)
            exit(2);
        snprintf(r[n].url, ul, "%s%s", base, p);
        r[n].body = sp && *sp ? strdup(sp) : NULL;
        n++;
    }
    fclose(f);
    if (!n) {
        fprintf(stderr, "load_client: no requests in %s\n", path);
        exit(2);
    }
    *count = n;
    return r;
}

static size_t on_body(char *p, size_t size, size_t n, void *ctx)
{
    (void)p;
    ((struct conn *)ctx)->bytes += size * n;
    return size * n;
}

static size_t on_header(char *p, size_t size, size_t n, void *ctx)
{
    if (size * n >= 12 && !strncasecmp(p, "Retry-After:", 12))
        ((struct conn *)ctx)->retry_after = 1;
    return size * n;
}

static void start(CURLM *m, struct conn *c, const struct request *req)
{
    c->req = req;
    c->retry_after = 0;
    c->bytes = 0;
    curl_easy_setopt(c->h, CURLOPT_URL, req->url);
    if (req->post) {
        curl_easy_setopt(c->h, CURLOPT_POSTFIELDS, req->body ? req->body : "");
        curl_easy_setopt(c->h, CURLOPT_HTTPHEADER, c->hdr);
    } else {
        curl_easy_setopt(c->h, CURLOPT_HTTPGET, 1L);
        curl_easy_setopt(c->h, CURLOPT_HTTPHEADER, NULL);
    }
    curl_multi_add_handle(m, c->h);
}

static void record(struct kind *k, uint32_t us)
{
    if (k->nlat == k->cap) {
        k->cap = k->cap ? 2 * k->cap : 4096;
        k->lat_us = realloc(k->lat_us, k->cap * sizeof *k->lat_us);
        if (!k->lat_us)
            exit(2);
    }
    k->lat_us[k->nlat++] = us;
}

static void finish(struct conn *c, CURLcode rc)
{
    struct kind *k = &kinds[c->req->kind];
    long status = 0;
    curl_off_t total = 0;
    curl_off_t length = -1;
    curl_easy_getinfo(c->h, CURLINFO_RESPONSE_CODE, &status);
    curl_easy_getinfo(c->h, CURLINFO_TOTAL_TIME_T, &total);
    curl_easy_getinfo(c->h, CURLINFO_CONTENT_LENGTH_DOWNLOAD_T, &length);
    k->n++;
    record(k, total > UINT32_MAX ? UINT32_MAX : (uint32_t)total);
    if (rc == CURLE_OK && status >= 200 && status < 300 &&
        (length < 0 || (uint64_t)length == c->bytes)) {
        k->ok++;
        return;
    }
    if (rc == CURLE_OK &&
        (status == 413 || status == 429 || (status == 503 && c->retry_after))) {
        k->limited++;
        return;
    }
    k->errors++;
    if (shown++ < MAX_SHOWN)
        fprintf(stderr, "load_client: %s %s: %s, status %ld\n",
                c->req->post ? "POST" : "GET", c->req->url,
                rc == CURLE_OK ? "no transport error" : curl_easy_strerror(rc),
                status);
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static double pct(const uint32_t *v, size_t n, double p)
{
    if (!n)
        return 0;
    size_t i = (size_t)(p * (double)(n - 1) + 0.5);
    return v[i] / 1000.0;
}

static void report_line(const char *name, uint64_t n, uint64_t okc, uint64_t lim,
                        uint64_t err, uint32_t *lat, size_t nlat, double secs)
{
    qsort(lat, nlat, sizeof *lat, cmp_u32);
    printf("%-8s %9llu %9llu %7llu %6llu %8.1f %8.2f %8.2f %8.2f %9.1f\n", name,
           (unsigned long long)n, (unsigned long long)okc,
           (unsigned long long)lim, (unsigned long long)err, n / secs,
           pct(lat, nlat, 0.50), pct(lat, nlat, 0.99), pct(lat, nlat, 0.999),
           nlat ? lat[nlat - 1] / 1000.0 : 0.0);
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: load_client BASE-URL CONNECTIONS SECONDS "
                "REQUESTS-FILE [INTERVAL]\n");
        return 2;
    }
    const char *base = argv[1];
    int nconn = atoi(argv[2]);
    double secs = atof(argv[3]);
    double interval = argc > 5 ? atof(argv[5]) : 10;
    if (nconn < 1 || nconn > 10000 || secs <= 0 || interval <= 0) {
        fprintf(stderr, "load_client: bad connections or seconds\n");
        return 2;
    }
    size_t nreq;
    struct request *reqs = load_requests(base, argv[4], &nreq);
    curl_global_init(CURL_GLOBAL_DEFAULT);
    CURLM *m = curl_multi_init();
    curl_multi_setopt(m, CURLMOPT_MAX_HOST_CONNECTIONS, (long)nconn);
    curl_multi_setopt(m, CURLMOPT_MAXCONNECTS, (long)nconn);
    struct conn *conns = calloc((size_t)nconn, sizeof *conns);
    if (!conns)
        return 2;
    size_t next = 0;
    for (int i = 0; i < nconn; i++) {
        struct conn *c = &conns[i];
        c->h = curl_easy_init();
        c->hdr = curl_slist_append(NULL, "Content-Type: application/json");
        curl_easy_setopt(c->h, CURLOPT_PRIVATE, c);
        curl_easy_setopt(c->h, CURLOPT_WRITEFUNCTION, on_body);
        curl_easy_setopt(c->h, CURLOPT_WRITEDATA, c);
        curl_easy_setopt(c->h, CURLOPT_HEADERFUNCTION, on_header);
        curl_easy_setopt(c->h, CURLOPT_HEADERDATA, c);
        curl_easy_setopt(c->h, CURLOPT_TIMEOUT, 60L);
        curl_easy_setopt(c->h, CURLOPT_NOSIGNAL, 1L);
        curl_easy_setopt(c->h, CURLOPT_TCP_NODELAY, 1L);
        /* Spread the connections over the request list. */
        next = (size_t)i * nreq / (size_t)nconn;
        start(m, c, &reqs[next]);
    }
    next = 0;
    const double t0 = now(), stop = t0 + secs;
    double tick = t0 + interval;
    uint64_t last_n = 0;
    int running = nconn;
    while (running > 0) {
        int still;
        curl_multi_perform(m, &still);
        CURLMsg *msg;
        int left;
        double t = now();
        while ((msg = curl_multi_info_read(m, &left))) {
            if (msg->msg != CURLMSG_DONE)
                continue;
            struct conn *c;
            CURL *h = msg->easy_handle;
            CURLcode rc = msg->data.result;
            curl_easy_getinfo(h, CURLINFO_PRIVATE, (char **)&c);
            curl_multi_remove_handle(m, h);
            finish(c, rc);
            if (t < stop) {
                start(m, c, &reqs[next]);
                next = (next + 1) % nreq;
            } else {
                running--;
            }
        }
        if (t >= tick) {
            uint64_t n = 0, err = 0, lim = 0;
            for (int k = 0; k < nkinds; k++) {
                n += kinds[k].n;
                err += kinds[k].errors;
                lim += kinds[k].limited;
            }
            fprintf(stderr, "progress t=%.0f requests=%llu rps=%.0f limited=%llu errors=%llu\n",
                    t - t0, (unsigned long long)n, (n - last_n) / (t - tick + interval),
                    (unsigned long long)lim, (unsigned long long)err);
            last_n = n;
            tick += interval;
        }
        if (running > 0)
            curl_multi_poll(m, NULL, 0, 100, NULL);
    }
    double elapsed = now() - t0;
    printf("%-8s %9s %9s %7s %6s %8s %8s %8s %8s %9s\n", "kind", "requests", "ok",
           "limited", "errors", "req/s", "p50_ms", "p99_ms", "p999_ms", "max_ms");
    uint64_t tn = 0, tok = 0, tlim = 0, terr = 0;
    size_t all_n = 0;
    for (int k = 0; k < nkinds; k++)
        all_n += kinds[k].nlat;
    uint32_t *all = malloc((all_n ? all_n : 1) * sizeof *all);
    size_t at = 0;
    for (int k = 0; k < nkinds; k++) {
        struct kind *kd = &kinds[k];
        memcpy(all + at, kd->lat_us, kd->nlat * sizeof *all);
        at += kd->nlat;
        tn += kd->n;
        tok += kd->ok;
        tlim += kd->limited;
        terr += kd->errors;
        report_line(kd->name, kd->n, kd->ok, kd->limited, kd->errors, kd->lat_us,
                    kd->nlat, elapsed);
    }
    report_line("all", tn, tok, tlim, terr, all, all_n, elapsed);
    free(all);
    for (int i = 0; i < nconn; i++) {
        curl_easy_cleanup(conns[i].h);
        curl_slist_free_all(conns[i].hdr);
    }
    free(conns);
    curl_multi_cleanup(m);
    curl_global_cleanup();
    for (int k = 0; k < nkinds; k++)
        free(kinds[k].lat_us);
    for (size_t i = 0; i < nreq; i++) {
        free(reqs[i].url);
        free(reqs[i].body);
    }
    free(reqs);
    return terr ? 1 : 0;
}
