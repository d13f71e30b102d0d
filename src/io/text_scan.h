/*
 * Numbers in text formats (OBJ, SMA, OFF): scanning tokens, choosing the
 * coordinate type of a text stream, and printing coordinates back.
 *
 * The coordinate-type rule (docs/method.md §11: output vertices are bit-identical input
 * vertices, so a float mesh must survive a text round trip):
 *   - A text stream has no declared coordinate type. It is FLOAT32 when every
 *     coordinate in its first EN_TEXT_PEEK_BYTES is "a float printed at its
 *     own precision": the float nearest to the text, printed with as many
 *     significant digits as the text has, gives back the text. Shortest
 *     output, %.9g and %f of a float all qualify. Otherwise it is FLOAT64.
 *   - In a FLOAT32 stream such a text reads as that float, so a float mesh
 *     written as text comes back bit-exact.
 *   - Any text more precise than a float (even past the peeked window) keeps
 *     its correctly rounded double: nothing written is lost.
 *   - In a FLOAT64 stream every text reads as its correctly rounded double.
 *
 * Printing (en_text_format_coord) is the inverse: the shortest %g-style text
 * that reads back to exactly the same float or double.
 */
#ifndef EN_IO_TEXT_SCAN_H
#define EN_IO_TEXT_SCAN_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "epsnet/epsnet.h"
#include "io/source.h"

/* Look-ahead that decides the coordinate type of a text stream. */
#define EN_TEXT_PEEK_BYTES ((size_t)64 << 10)

/* Blanks separate tokens on a line; '\n' never reaches the scanners. */
static inline int en_text_is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

static inline char *en_text_skip_blanks(char *p)
{
    while (en_text_is_blank(*p))
        p++;
    return p;
}

/* p without the blanks around it (a statement's or a comment's text): its
 * start, and its length into *n. */
static inline const char *en_text_trim(const char *p, size_t *n)
{
    p = en_text_skip_blanks((char *)p);
    size_t k = strlen(p);
    while (k && en_text_is_blank(p[k - 1]))
        k--;
    *n = k;
    return p;
}

static inline int en_text_ends_token(char c)
{
    return c == '\0' || en_text_is_blank(c);
}

/* Length of the token at p, capped at 40 for quoting in messages. */
int en_text_quoted_len(const char *p);

/*
 * Signed decimal integer right at *pp (no blank skipping, no check of what
 * follows). @return 0 with *out set and *pp past the digits, or -1 when
 * there is no digit or the value overflows int64 (*pp unchanged).
 */
int en_text_scan_int64(char **pp, int64_t *out);

/*
 * Significant decimal digits of the number text [p, end), and the power of
 * ten of the last one: leading and trailing zeros of the mantissa do not
 * count ("0.0120" has 2 digits, the last at 10^-3; "1.5e3" 2 at 10^2).
 */
int en_text_significant_digits(const char *p, const char *end, int *last_exp10);

/* True when the number text [p, end) is the float f (strtof of the text)
 * printed at the text's own precision (see the rule above). */
int en_text_is_float_text(const char *p, const char *end, float f);

/*
 * Next coordinate on a NUL-terminated line, after blanks, read by the rule
 * above for a stream of the given type.
 * @return 1 with *out set and *pp past the token, 0 at the end of the line,
 * -1 when the token is not a number (*pp then points at it).
 */
int en_text_scan_coord(char **pp, epsnet_coord_type type, double *out);

/* Copy the token at p (up to a blank, '\n' or end) into buf, truncated to
 * cap - 1 bytes and NUL-terminated. @return its length. */
size_t en_text_copy_token(const char *p, const char *end, char *buf, size_t cap);

/*
 * Coordinate type of a text stream by the rule above, looking at the first
 * EN_TEXT_PEEK_BYTES of src without consuming them. Coordinate lines are
 * those whose first word is keyword ("v"), or with keyword NULL every line
 * that is neither blank nor a '#' comment; of each, the first three tokens
 * are examined (text from a '#' on is ignored), for at most max_lines lines.
 * A read error leaves src->failed set for the caller to report.
 */
epsnet_coord_type en_text_peek_coord_type(en_source *src, const char *keyword, uint64_t max_lines);

/*
 * Shortest text that reads back (strtod, or strtof for FLOAT32) to exactly v
 * (to (float)v for FLOAT32), in %g style: the first precision p from 6
 * (FLOAT32) or 15 (FLOAT64) upwards whose %.{p}g text round-trips, up to 9
 * or 17 which always do. buf must hold 32 bytes. @return the text length.
 */
int en_text_format_coord(char *buf, double v, epsnet_coord_type type);

/*
 * The exact fast method behind en_text_format_coord: the same text, or 0
 * when the value is too close to a rounding or round-trip border for its
 * 128-bit arithmetic to decide (rare; then only the slow search decides).
 */
int en_text_format_coord_fast(char *buf, double v, epsnet_coord_type type);

#endif /* EN_IO_TEXT_SCAN_H */
