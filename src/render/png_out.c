#include "render/png_out.h"

#include <png.h>
#include <setjmp.h>
#include <stdio.h>

#include "common/alloc.h"
#include "common/error.h"
#include "io/sink.h"

/* What the libpng callbacks learn, for the message after a longjmp. */
typedef struct png_job {
    const char *path;
    en_sink *sink;
    epsnet_error *err;
    int sink_rc;          /* the sink's code when a write failed (err filled) */
    int out_of_memory;    /* an allocation for libpng failed */
    char message[256];    /* libpng's own reason otherwise */
} png_job;

static void on_png_error(png_structp png, png_const_charp msg)
{
    png_job *job = png_get_error_ptr(png);
    snprintf(job->message, sizeof job->message, "%s", msg ? msg : "unknown libpng error");
    png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* note: libpng's memory goes through en_malloc so fault injection reaches
 * it like any other allocation of the library. */
static png_voidp on_png_malloc(png_structp png, png_alloc_size_t n)
{
    void *p = en_malloc(n ? n : 1);
    if (!p && png) {
        png_job *job = png_get_mem_ptr(png);
        if (job)
            job->out_of_memory = 1;
    }
    return p;
}

static void on_png_free(png_structp png, png_voidp p)
{
    (void)png;
    en_free(p);
}

static void on_png_write(png_structp png, png_bytep data, size_t n)
{
    png_job *job = png_get_io_ptr(png);
    int rc = en_sink_write(job->sink, data, n, job->err);
    if (rc) {
        job->sink_rc = rc;
        png_error(png, "write failed");
    }
}

static void on_png_flush(png_structp png)
{
    (void)png;
}

static int encoder_failure(const png_job *job)
{
    if (job->sink_rc)
        return job->sink_rc;
    if (job->out_of_memory)
        return en_error_set(job->err, EPSNET_ENOMEM, job->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory encoding the PNG");
    return en_error_set(job->err, EPSNET_EINTERNAL, job->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "PNG encoder: %s", job->message);
}

static int encode(png_job *job, const uint8_t *rgb, uint32_t width, uint32_t height)
{
    png_structp png = png_create_write_struct_2(PNG_LIBPNG_VER_STRING, job, on_png_error, on_png_warning, job,
                                                on_png_malloc, on_png_free);
    if (!png)
        return en_error_set(job->err, EPSNET_ENOMEM, job->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory starting the PNG encoder");
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        return en_error_set(job->err, EPSNET_ENOMEM, job->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory starting the PNG encoder");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return encoder_failure(job);
    }
    png_set_write_fn(png, job, on_png_write, on_png_flush);
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    /* note: the highest zlib level; renders are small and written once, and
     * the README gallery is committed. */
    png_set_compression_level(png, 9);
    png_write_info(png, info);
    for (uint32_t y = 0; y < height; y++)
        png_write_row(png, rgb + (size_t)3 * width * y);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

int en_png_write(const char *path, const uint8_t *rgb, uint32_t width, uint32_t height, epsnet_error *err)
{
    if (width == 0 || height == 0 || width > PNG_USER_WIDTH_MAX || height > PNG_USER_HEIGHT_MAX)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "image size %ux%u is not possible in a PNG", width, height);
    png_job job = { .path = path, .err = err };
    int rc = en_sink_open(&job.sink, path, 0, err);
    if (rc)
        return rc;
    rc = encode(&job, rgb, width, height);
    if (rc == 0)
        return en_sink_commit(&job.sink, err);
    en_sink_abort(&job.sink);
    return rc;
}
