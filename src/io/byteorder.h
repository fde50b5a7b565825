/* byteorder.h: fixed byte order for the binary files dtx writes and reads
 * (glb and the view page's blobs: little-endian; PC2: little-endian; MDD:
 * big-endian), whatever the machine's own order.
 *   dtx_put_*: write a value's bytes at p (2 or 4 bytes).
 *   dtx_get_*: read them back.
 * Floats and signed integers travel as the bits of a uint32. */
#ifndef DTX_IO_BYTEORDER_H
#define DTX_IO_BYTEORDER_H

#include <stdint.h>
#include <string.h>

static inline void dtx_put_le16(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v & 0xffu);
    p[1] = (unsigned char)((v >> 8) & 0xffu);
}

static inline void dtx_put_le32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v & 0xffu);
    p[1] = (unsigned char)((v >> 8) & 0xffu);
    p[2] = (unsigned char)((v >> 16) & 0xffu);
    p[3] = (unsigned char)((v >> 24) & 0xffu);
}

static inline void dtx_put_be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)((v >> 24) & 0xffu);
    p[1] = (unsigned char)((v >> 16) & 0xffu);
    p[2] = (unsigned char)((v >> 8) & 0xffu);
    p[3] = (unsigned char)(v & 0xffu);
}

static inline uint32_t dtx_get_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline uint32_t dtx_get_be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

/* The bits of a float or an int32 as a uint32, and back. */
static inline uint32_t dtx_f32_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static inline float dtx_bits_f32(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static inline int32_t dtx_bits_i32(uint32_t u)
{
    int32_t v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static inline void dtx_put_lef32(unsigned char *p, float f) { dtx_put_le32(p, dtx_f32_bits(f)); }
static inline void dtx_put_bef32(unsigned char *p, float f) { dtx_put_be32(p, dtx_f32_bits(f)); }
static inline float dtx_get_lef32(const unsigned char *p) { return dtx_bits_f32(dtx_get_le32(p)); }
static inline float dtx_get_bef32(const unsigned char *p) { return dtx_bits_f32(dtx_get_be32(p)); }
static inline int32_t dtx_get_lei32(const unsigned char *p)
{
    return dtx_bits_i32(dtx_get_le32(p));
}
static inline int32_t dtx_get_bei32(const unsigned char *p)
{
    return dtx_bits_i32(dtx_get_be32(p));
}

#endif
