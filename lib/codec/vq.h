/*
 * vq.h - nearest-codevector search and LBG training for the tile encoder.
 *
 * Vectors are int16 with a stride of VQ_STRIDE lanes (dimension 4 or 12,
 * zero padded).  Codebooks are signed 8-bit, as stored in tile buffers.
 * The search is exact (ties go to the lowest index) and gives identical
 * answers on the AVX-512, AVX2 and portable paths, so encoding is
 * deterministic on every machine.  Each codevector may carry an integer
 * bias added to its squared distance (entropy-constrained VQ: the bias is
 * lambda times the codevector's code length).  Internal to the tile
 * encoder; one thread per vq_search or vq_trainer (the structures are
 * large: allocate them, as the tile workspace does).
 */
#ifndef GV_VQ_H
#define GV_VQ_H

#include <stddef.h>
#include <stdint.h>

#define VQ_STRIDE 16
#define VQ_MAXDIM 12
#define VQ_MAXK 4096

/* The largest bias: a biased cost (at most VQ_BIAS_MAX + 12 * 383^2) stays
 * in int32 and below the cost of any padding lane. */
#define VQ_BIAS_MAX (1 << 30)

/* A codebook prepared for searching.  The codevectors are sorted by the
 * sum of their components (stable, so equal sums keep index order), and
 * their pairs of dimensions packed into int32 lanes, [dim/2][kpad] in that
 * order (structure of arrays); orig[p] is the index of the codevector at
 * position p, bias[p] its bias (0 in the padding lanes).  For each run
 * of 16 positions, the least and greatest sum and the least bias bound
 * the cost of its codevectors from below (Cauchy-Schwarz:
 * dim * |x - c|^2 >= (sum x - sum c)^2), so the SIMD searches skip runs
 * that cannot hold the answer. */
struct vq_search {
    int k, dim;
    int kpad;               /* k rounded up to 16: the SIMD row stride */
    int32_t pairs[VQ_MAXDIM / 2 * VQ_MAXK];
    int32_t bias[VQ_MAXK];
    int32_t orig[VQ_MAXK];  /* position -> index; padding: INT32_MAX */
    int32_t pos[VQ_MAXK];   /* index -> position */
    int32_t run_smin[VQ_MAXK / 16], run_smax[VQ_MAXK / 16];
    int32_t run_bmin[VQ_MAXK / 16];
    uint16_t run_at[256 * VQ_MAXDIM + 1]; /* sum + 128 * VQ_MAXDIM -> the
                                           * first run reaching it (or the last) */
};

/* Prepare `book` (k entries of dim signed bytes) for vq_nearest, with
 * every bias 0 (plain nearest search). */
void vq_search_prepare(struct vq_search *s, const int8_t *book, int k, int dim);

/* Set the biases of a prepared search: bias[c] is added to the squared
 * distance to codevector c; each is clamped to 0 .. VQ_BIAS_MAX.  NULL
 * sets every bias to 0. */
void vq_search_set_bias(struct vq_search *s, const int32_t *bias);

/*
 * For each of the n vectors, the index c minimizing the squared distance
 * plus bias[c] in idx[i] (ties to the lowest index) and, if dist is not
 * NULL, that cost (the squared distance when biases are 0) in dist[i].
 */
void vq_nearest(const struct vq_search *s, const int16_t *vecs, size_t n,
                uint16_t *idx, uint32_t *dist);

/*
 * vq_nearest started from a guess: idx[i] holds, on entry, an index below
 * s->k for vector i (a previous assignment, say).  Its cost bounds the
 * search from the start, so the SIMD paths skip more runs of
 * codevectors.  The answers (and dist) are exactly vq_nearest's, whatever
 * the guesses.
 */
void vq_nearest_warm(const struct vq_search *s, const int16_t *vecs, size_t n,
                     uint16_t *idx, uint32_t *dist);

/* The largest training sample (a tile's blocks). */
#define VQ_TRAIN_MAXN (257 * 257)

/* Scratch for vq_train: sized for VQ_MAXK entries. */
struct vq_trainer {
    int dim, k;
    int8_t book[VQ_MAXK * VQ_MAXDIM];
    int64_t sum[VQ_MAXK * VQ_MAXDIM];
    uint32_t count[VQ_MAXK];
    int32_t bias[VQ_MAXK];  /* vq_train_ecvq: lambda * code length */
    uint32_t members[VQ_TRAIN_MAXN]; /* splitting: sample rows by cell */
    struct vq_search search;
};

/* Start a trainer with one codevector: the rounded mean of the sample. */
void vq_train_init(struct vq_trainer *t, int dim, const int16_t *sample,
                   size_t n);

/*
 * Double the codebook by splitting every cell along its principal axis
 * (PCA split, section 2.7), then refine with LBG on the sample until the
 * distortion improves by less than 0.5% or max_iters assignments pass.
 * Empty cells are reseeded with the worst-coded sample vectors.  idx and
 * dist are caller scratch of n entries; n is at most VQ_TRAIN_MAXN.  Returns the sample distortion of
 * the last assignment.
 */
uint64_t vq_train_double(struct vq_trainer *t, const int16_t *sample, size_t n,
                         int max_iters, uint16_t *idx, uint32_t *dist);

/* Start a trainer from a given codebook of k entries of dim bytes. */
void vq_train_from(struct vq_trainer *t, const int8_t *book, int k, int dim);

/*
 * Entropy-constrained refinement of t's codebook on the sample: `iters`
 * rounds of (assignment by squared distance + t->bias, code lengths
 * -log2(count / n) from that assignment, bias = round(lambda * length),
 * every used cell to the mean of its vectors).  The first assignment is
 * unbiased; a cell that empties keeps its codevector and gets the length
 * of half a vector, log2(2n).  lambda is squared error per bit, in the
 * distance's units.  On return t->bias holds the biases from the last
 * assignment and t->search is prepared with the final book and those
 * biases, ready for vq_nearest.  Integer arithmetic apart from IEEE
 * divisions (the means) and one multiplication per bias, so the result
 * is the same on every CPU.
 * With warm, idx holds on entry an assignment of the sample to indices
 * below t->k (the LBG one, say) that starts the first search
 * (vq_nearest_warm); that changes only the time taken.  Each later round
 * starts from the previous round's assignment.
 * Returns the sample's last biased cost (distortion + lambda * bits).
 */
uint64_t vq_train_ecvq(struct vq_trainer *t, const int16_t *sample, size_t n,
                       double lambda, int iters, int warm, uint16_t *idx,
                       uint32_t *dist);

/* Count the assignment idx (n entries) into t->count and set t->bias[c]
 * to round(lambda * len_c), len_c = -log2(count_c / n) in 16.16 fixed
 * point (log2(2n) for an empty cell), clamped to VQ_BIAS_MAX. */
void vq_set_biases(struct vq_trainer *t, const uint16_t *idx, size_t n,
                   double lambda);

/* log2(x) in 16.16 fixed point for x >= 1: floor(log2(x) * 65536) or one
 * less (the mantissa is truncated as it is squared), by integer arithmetic
 * only, so that code lengths are the same on every CPU. */
uint32_t vq_log2_q16(uint64_t x);

#endif
