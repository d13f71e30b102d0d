/*
 * The one interface every step of the chain speaks (docs/architecture.md
 * §7): take a record; end. Reader → sort → ε-net pass 1 … K → writer, each
 * the next one's producer, none knowing the others' insides (the shape of
 * Isenburg and Lindstrom's streaming-mesh filters, a reader over a reader,
 * here pushed instead of pulled so that workers can run ahead).
 */
#ifndef EN_COMMON_STAGE_H
#define EN_COMMON_STAGE_H

#include "epsnet/epsnet.h"

/* Take one record. @return 0, or a negative code with err filled. */
typedef int (*en_put_fn)(void *self, const epsnet_record *rec, epsnet_error *err);
/* No more records: finish and pass the end on. @return as put. */
typedef int (*en_end_fn)(void *self, epsnet_error *err);

typedef struct en_stage {
    en_put_fn put;
    en_end_fn end;     /* NULL: nothing to finish (the owner closes it) */
    void *self;
} en_stage;

static inline int en_stage_put(const en_stage *s, const epsnet_record *rec, epsnet_error *err)
{
    return s->put(s->self, rec, err);
}

static inline int en_stage_end(const en_stage *s, epsnet_error *err)
{
    return s->end ? s->end(s->self, err) : 0;
}

/* A stage that takes every record and keeps none (a pricing pass's
 * output, another rank's share of a run). */
static inline int en_stage_discard_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    (void)self;
    (void)rec;
    (void)err;
    return 0;
}
#define EN_STAGE_DISCARD ((en_stage){ en_stage_discard_put, NULL, NULL })

#endif
