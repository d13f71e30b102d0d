/*
 * Per-vertex attribute layouts (epsnet.h §2): the type table, building and
 * checking layouts, and which attributes each output format holds
 * (docs/architecture.md §5: what an output cannot hold is named, never
 * dropped silently).
 */
#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"

static const struct {
    size_t size;
    const char *name;
} attr_types[] = {
    [EPSNET_ATTR_INT8] = { 1, "char" },    [EPSNET_ATTR_UINT8] = { 1, "uchar" },
    [EPSNET_ATTR_INT16] = { 2, "short" },  [EPSNET_ATTR_UINT16] = { 2, "ushort" },
    [EPSNET_ATTR_INT32] = { 4, "int" },    [EPSNET_ATTR_UINT32] = { 4, "uint" },
    [EPSNET_ATTR_FLOAT32] = { 4, "float" }, [EPSNET_ATTR_FLOAT64] = { 8, "double" },
};

size_t epsnet_attr_type_size(epsnet_attr_type t)
{
    return t >= EPSNET_ATTR_INT8 && t <= EPSNET_ATTR_FLOAT64 ? attr_types[t].size : 0;
}

const char *epsnet_attr_type_name(epsnet_attr_type t)
{
    return t >= EPSNET_ATTR_INT8 && t <= EPSNET_ATTR_FLOAT64 ? attr_types[t].name : NULL;
}

int epsnet_attr_layout_find(const epsnet_attr_layout *l, const char *name)
{
    for (uint32_t i = 0; l && name && i < l->count && i < EPSNET_ATTR_MAX; i++)
        if (strcmp(l->attr[i].name, name) == 0)
            return (int)i;
    return -1;
}

/* note: names travel into PLY headers and .smz tables, which separate
 * words by white space: a name must be one printable word. */
static int bad_name(const char *name)
{
    size_t n = strnlen(name, EPSNET_ATTR_NAME_MAX);
    if (n == 0 || n == EPSNET_ATTR_NAME_MAX)
        return 1;
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)name[i] <= ' ' || (unsigned char)name[i] == 0x7f)
            return 1;
    return 0;
}

int epsnet_attr_layout_add(epsnet_attr_layout *l, const char *name, epsnet_attr_type type)
{
    if (!l || !name || !epsnet_attr_type_size(type) || bad_name(name) || l->count > EPSNET_ATTR_MAX ||
        epsnet_attr_layout_find(l, name) >= 0)
        return EPSNET_EINVAL;
    if (l->count == EPSNET_ATTR_MAX)
        return EPSNET_ELIMIT;
    epsnet_attr *a = &l->attr[l->count++];
    memset(a, 0, sizeof *a);
    memcpy(a->name, name, strlen(name) + 1);
    a->type = type;
    a->offset = l->size;
    l->size += (uint32_t)epsnet_attr_type_size(type);
    return 0;
}

int en_attr_layout_add_as(epsnet_attr_layout *l, const char *name, epsnet_attr_type type, int of_face)
{
    int rc = epsnet_attr_layout_add(l, name, type);
    if (rc == 0)
        l->attr[l->count - 1].of_face = of_face != 0;
    return rc;
}

int epsnet_attr_layout_add_of_face(epsnet_attr_layout *l, const char *name, epsnet_attr_type type)
{
    return en_attr_layout_add_as(l, name, type, 1);
}

int en_attr_layout_check(const epsnet_attr_layout *l, char *why, size_t why_len)
{
    if (l->count > EPSNET_ATTR_MAX) {
        snprintf(why, why_len, "%u vertex attributes, more than %d", l->count, EPSNET_ATTR_MAX);
        return -1;
    }
    uint32_t at = 0;
    for (uint32_t i = 0; i < l->count; i++) {
        const epsnet_attr *a = &l->attr[i];
        if (bad_name(a->name)) {
            snprintf(why, why_len, "vertex attribute %u has an empty, overlong or spaced name", i + 1);
            return -1;
        }
        if (!epsnet_attr_type_size(a->type)) {
            snprintf(why, why_len, "vertex attribute '%s' has an unknown type %d", a->name, (int)a->type);
            return -1;
        }
        if (a->of_face > 1) {
            snprintf(why, why_len, "vertex attribute '%s' has of_face %u (0 or 1)", a->name, a->of_face);
            return -1;
        }
        if (a->offset != at) {
            snprintf(why, why_len, "vertex attribute '%s' is at offset %u, expected %u (packed)", a->name,
                     a->offset, at);
            return -1;
        }
        for (uint32_t k = 0; k < i; k++)
            if (strcmp(l->attr[k].name, a->name) == 0) {
                snprintf(why, why_len, "vertex attribute '%s' appears twice", a->name);
                return -1;
            }
        at += (uint32_t)epsnet_attr_type_size(a->type);
    }
    if (l->size != at) {
        snprintf(why, why_len, "vertex attributes have size %u, expected %u", l->size, at);
        return -1;
    }
    return 0;
}

int en_format_holds_every_attr(const epsnet_attr_layout *l, uint32_t i)
{
    (void)l;
    (void)i;
    return 1;
}

const char *const en_face_label_attr[2] = { "material_index", "group_index" };

int en_face_names_copy_of(en_face_names_copy *to, const epsnet_face_names *from)
{
    memset(to, 0, sizeof *to);
    if (!from)
        return 0;
    size_t bytes = (size_t)from->count * sizeof(char *) + (from->library ? strlen(from->library) + 1 : 0);
    for (uint32_t i = 0; i < from->count; i++)
        bytes += strlen(from->names[i]) + 1;
    if (!(to->storage = en_malloc(bytes ? bytes : 1)))
        return EPSNET_ENOMEM;
    const char **names = to->storage;
    char *text = (char *)(names + from->count);
    for (uint32_t i = 0; i < from->count; i++) {
        size_t n = strlen(from->names[i]) + 1;
        names[i] = memcpy(text, from->names[i], n);
        text += n;
    }
    if (from->library)
        to->names.library = memcpy(text, from->library, strlen(from->library) + 1);
    to->names.count = from->count;
    to->names.names = names;
    to->of = &to->names;
    return 0;
}

void en_face_names_copy_free(en_face_names_copy *c)
{
    en_free(c->storage);
    memset(c, 0, sizeof *c);
}
