/*
 * vq.h - nearest-codevector search and LBG training for the tile encoder.
 *
 * Vectors are int16 with a stride of VQ_STRIDE lanes (dimension 4 or 12,
 * zero padded).  Codebooks are signed 8-bit, as stored in tile buffers.
 * The search is exact (ties go to the lowest index) and gives identical
 * answers on the AVX-512, AVX2 and portable paths, so encoding is
 * deterministic on every machine.  Internal to the tile encoder; one
 * thread per vq_search or vq_trainer (the structures are large: allocate
 * them, as the tile workspace does).
 */
#ifndef GV_VQ_H
#define GV_VQ_H

#include <stddef.h>
#include <stdint.h>

#define VQ_STRIDE 16
#define VQ_MAXDIM 12
#define VQ_MAXK 4096

/* A codebook prepared for searching: pairs of dimensions packed into int32
 * lanes, [dim/2][k] (structure of arrays). */
struct vq_search {
    int k, dim;
    int kpad;               /* k rounded up to 16: the SIMD row stride */
    int32_t pairs[VQ_MAXDIM / 2 * VQ_MAXK];
};

/* Prepare `book` (k entries of dim signed bytes) for vq_nearest. */
void vq_search_prepare(struct vq_search *s, const int8_t *book, int k, int dim);

/*
 * For each of the n vectors, the index of the nearest codevector in idx[i]
 * and, if dist is not NULL, its squared distance in dist[i].
 */
void vq_nearest(const struct vq_search *s, const int16_t *vecs, size_t n,
                uint16_t *idx, uint32_t *dist);

/* Scratch for vq_train: sized for VQ_MAXK entries. */
struct vq_trainer {
    int dim, k;
    int8_t book[VQ_MAXK * VQ_MAXDIM];
    int64_t sum[VQ_MAXK * VQ_MAXDIM];
    uint32_t count[VQ_MAXK];
    struct vq_search search;
};

/* Start a trainer with one codevector: the rounded mean of the sample. */
void vq_train_init(struct vq_trainer *t, int dim, const int16_t *sample,
                   size_t n);

/*
 * Double the codebook by splitting every cell along its principal axis
 * (PCA split, section 2.7), then refine with LBG on the sample until the
 * distortion improves by less than 0.5% or 12 iterations pass.  Empty
 * cells are reseeded with the worst-coded sample vectors.  idx and dist
 * are caller scratch of n entries.  Returns the final sample distortion.
 */
uint64_t vq_train_double(struct vq_trainer *t, const int16_t *sample, size_t n,
                         uint16_t *idx, uint32_t *dist);

#endif
