/* The format table. Order matters only for content
 * probing ties. */
#include <pthread.h>
#include <string.h>
#include <strings.h>

#include "io/format.h"

extern const en_format en_format_ply;
extern const en_format en_format_obj;
extern const en_format en_format_off;
extern const en_format en_format_stl;
extern const en_format en_format_sma;
extern const en_format en_format_smb;
extern const en_format en_format_smz;

const en_format *const en_formats[] = {
    &en_format_ply, &en_format_obj, &en_format_off, &en_format_stl,
    &en_format_sma, &en_format_smb, &en_format_smz, NULL,
};

const en_format *en_format_by_name(const char *name)
{
    for (size_t i = 0; en_formats[i]; i++)
        if (strcasecmp(en_formats[i]->name, name) == 0)
            return en_formats[i];
    return NULL;
}

const en_format *en_format_by_path(const char *path)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    size_t n = strlen(base);
    if (n > 4 && strcasecmp(base + n - 4, ".zst") == 0)
        n -= 4;
    const char *dot = NULL;
    for (size_t i = n; i > 0; i--)
        if (base[i - 1] == '.') {
            dot = base + i;
            break;
        }
    if (!dot)
        return NULL;
    size_t elen = (size_t)(base + n - dot);
    for (size_t i = 0; en_formats[i]; i++) {
        const char *e = en_formats[i]->extensions;
        while (*e) {
            size_t k = strcspn(e, " ");
            if (k == elen && strncasecmp(e, dot, k) == 0)
                return en_formats[i];
            e += k;
            while (*e == ' ')
                e++;
        }
    }
    return NULL;
}

/* The two name lists are built once from the table; pthread_once makes the
 * first call safe from any thread (the public API may be called from many). */
static char format_lists[2][128];
static pthread_once_t format_lists_once = PTHREAD_ONCE_INIT;

static void build_format_lists(void)
{
    for (int writable = 0; writable < 2; writable++) {
        char *b = format_lists[writable];
        for (size_t i = 0; en_formats[i]; i++) {
            if (writable && !en_formats[i]->open_writer)
                continue;
            if (b[0])
                strcat(b, " ");
            strcat(b, en_formats[i]->name);
        }
    }
}

const char *epsnet_formats_readable(void)
{
    pthread_once(&format_lists_once, build_format_lists);
    return format_lists[0];
}

const char *epsnet_formats_writable(void)
{
    pthread_once(&format_lists_once, build_format_lists);
    return format_lists[1];
}
