/*
 * The 64-bit mix that spreads vertex ids and ranks (nearly consecutive
 * numbers) over the slots of the open-addressing tables: u64set, u64map and
 * sort's live map (MurmurHash3's finalizer steps).
 */
#ifndef EN_COMMON_HASH64_H
#define EN_COMMON_HASH64_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* Slot of key k in a table of mask + 1 slots (a power of two). */
static inline size_t en_hash_slot(uint64_t k, size_t mask)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    return (size_t)k & mask;
}

/* A 64-bit key of a position's coordinate bits, never UINT64_MAX (the
 * tables' reserved key): a cheap fold, spread over the slots by
 * en_hash_slot; equal positions share it, and the rare two that are not
 * equal and still share it are for the caller to tolerate (the chunker's
 * live positions, the slabs' quick test for shared positions). */
static inline uint64_t en_position_key(const double xyz[3])
{
    uint64_t b[3];
    memcpy(b, xyz, sizeof b);
    uint64_t h = b[0] ^ (b[1] << 21 | b[1] >> 43) ^ (b[2] << 42 | b[2] >> 22);
    return h == UINT64_MAX ? h - 1 : h;
}

/* FNV-1a of n bytes: a key for byte strings (names, fixed-size records)
 * that the tables above then spread with en_hash_slot. */
static inline uint64_t en_hash_bytes(const void *p, size_t n)
{
    const uint8_t *b = p;
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

/* Backward-shift deletion: may the entry at slot j, whose home slot is home,
 * move back into the hole at slot hole? (Only when its home is not in
 * (hole, j], cyclically, or probing for it would stop at the hole.) */
static inline int en_hash_can_fill(size_t home, size_t hole, size_t j, size_t mask)
{
    return ((j - home) & mask) >= ((j - hole) & mask);
}

#endif
