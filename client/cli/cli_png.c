#include "cli_png.h"

#include <errno.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* libpng reports errors through a callback that must not return: it longjmps back to the
 * setjmp of the call in progress, with the message kept here. */
typedef struct png_failure {
    jmp_buf jump;
    char message[200];
} png_failure;

static void on_png_error(png_structp png, png_const_charp message)
{
    png_failure *f = png_get_error_ptr(png);
    snprintf(f->message, sizeof f->message, "%s", message);
    longjmp(f->jump, 1);
}

static void on_png_warning(png_structp png, png_const_charp message)
{
    (void)png;
    (void)message; /* a warning changes nothing the caller can act on */
}

static int color_type_for(int channels)
{
    return channels == 2 ? PNG_COLOR_TYPE_GRAY_ALPHA : PNG_COLOR_TYPE_RGB_ALPHA;
}

/* One row in the file's byte order: 16-bit samples big-endian, as PNG stores them. */
static void pack_row(const cli_png_image *img, int y, png_byte *row)
{
    size_t n = (size_t)img->width * (size_t)img->channels;
    const uint16_t *s = img->samples + (size_t)y * n;
    for (size_t i = 0; i < n; i++) {
        if (img->bit_depth == 16) {
            row[2 * i] = (png_byte)(s[i] >> 8);
            row[2 * i + 1] = (png_byte)(s[i] & 0xff);
        } else {
            row[i] = (png_byte)(s[i] & 0xff);
        }
    }
}

int cli_png_write(const char *path, const cli_png_image *img, char *err, size_t err_len)
{
    if ((img->channels != 2 && img->channels != 4) || (img->bit_depth != 8 && img->bit_depth != 16) ||
        img->width < 1 || img->height < 1 || img->num_text > CLI_PNG_MAX_TEXT) {
        snprintf(err, err_len, "%s: not an image trioct writes", path);
        return -1;
    }
    FILE *file = fopen(path, "wb");
    if (file == NULL) {
        snprintf(err, err_len, "cannot create %s: %s", path, strerror(errno));
        return -1;
    }
    size_t row_bytes = (size_t)img->width * (size_t)img->channels * (size_t)(img->bit_depth / 8);
    /* volatile: they change between setjmp and a longjmp back to it. */
    png_byte *volatile row = malloc(row_bytes);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png != NULL ? png_create_info_struct(png) : NULL;
    png_failure failure = {.message = "out of memory"};
    int rc = -1;
    if (row == NULL || png == NULL || info == NULL)
        goto done;
    png_set_error_fn(png, &failure, on_png_error, on_png_warning);
    if (setjmp(failure.jump) != 0)
        goto done;
    png_init_io(png, file);
    png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height, img->bit_depth,
                 color_type_for(img->channels), PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_text text[CLI_PNG_MAX_TEXT];
    for (size_t i = 0; i < img->num_text; i++) {
        memset(&text[i], 0, sizeof text[i]);
        text[i].compression = PNG_TEXT_COMPRESSION_NONE;
        text[i].key = (png_charp)img->text[i].key;
        text[i].text = (png_charp)img->text[i].value;
    }
    if (img->num_text > 0)
        png_set_text(png, info, text, (int)img->num_text);
    png_write_info(png, info);
    for (int y = 0; y < img->height; y++) {
        pack_row(img, y, row);
        png_write_row(png, row);
    }
    png_write_end(png, info);
    rc = 0;
done:
    png_destroy_write_struct(png != NULL ? &png : NULL, info != NULL ? &info : NULL);
    free(row);
    if (fclose(file) != 0 && rc == 0) {
        snprintf(failure.message, sizeof failure.message, "%s", strerror(errno));
        rc = -1;
    }
    if (rc != 0) {
        snprintf(err, err_len, "cannot write %s: %s", path, failure.message);
        unlink(path);
    }
    return rc;
}

int cli_png_read(const char *path, cli_png_image *img, char *err, size_t err_len)
{
    memset(img, 0, sizeof *img);
    FILE *file = fopen(path, "rb");
    if (file == NULL) {
        snprintf(err, err_len, "cannot open %s: %s", path, strerror(errno));
        return -1;
    }
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png != NULL ? png_create_info_struct(png) : NULL;
    png_failure failure = {.message = "out of memory"};
    png_byte *volatile row = NULL;
    uint16_t *volatile samples = NULL;
    int rc = -1;
    if (png == NULL || info == NULL)
        goto done;
    png_set_error_fn(png, &failure, on_png_error, on_png_warning);
    if (setjmp(failure.jump) != 0)
        goto done;
    png_init_io(png, file);
    png_read_info(png, info);
    png_uint_32 width = png_get_image_width(png, info), height = png_get_image_height(png, info);
    int depth = png_get_bit_depth(png, info), type = png_get_color_type(png, info);
    int channels = type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2 : type == PNG_COLOR_TYPE_RGB_ALPHA ? 4 : 0;
    if (channels == 0 || (depth != 8 && depth != 16) || png_get_interlace_type(png, info) != PNG_INTERLACE_NONE ||
        width > 65536 || height > 65536) {
        snprintf(failure.message, sizeof failure.message, "not a grey-alpha or RGBA image of 8 or 16 bits");
        goto done;
    }
    size_t n = (size_t)width * (size_t)channels;
    row = malloc(n * 2);
    samples = malloc(n * (size_t)height * sizeof *samples);
    if (row == NULL || samples == NULL) {
        snprintf(failure.message, sizeof failure.message, "out of memory");
        goto done;
    }
    for (png_uint_32 y = 0; y < height; y++) {
        png_read_row(png, row, NULL);
        uint16_t *s = samples + (size_t)y * n;
        for (size_t i = 0; i < n; i++)
            s[i] = depth == 16 ? (uint16_t)(row[2 * i] << 8 | row[2 * i + 1]) : row[i];
    }
    png_read_end(png, info);
    png_textp text = NULL;
    int num_text = png_get_text(png, info, &text, NULL);
    for (int i = 0; i < num_text && img->num_text < CLI_PNG_MAX_TEXT; i++) {
        cli_png_text *t = &img->text[img->num_text++];
        snprintf(t->key, sizeof t->key, "%s", text[i].key);
        snprintf(t->value, sizeof t->value, "%s", text[i].text);
    }
    img->width = (int)width;
    img->height = (int)height;
    img->channels = channels;
    img->bit_depth = depth;
    img->samples = samples;
    samples = NULL;
    rc = 0;
done:
    png_destroy_read_struct(png != NULL ? &png : NULL, info != NULL ? &info : NULL, NULL);
    free(row);
    free(samples);
    fclose(file);
    if (rc != 0)
        snprintf(err, err_len, "cannot read %s: %s", path, failure.message);
    return rc;
}

void cli_png_image_free(cli_png_image *img)
{
    free(img->samples);
    img->samples = NULL;
}

const char *cli_png_text_get(const cli_png_image *img, const char *key)
{
    for (size_t i = 0; i < img->num_text; i++)
        if (strcmp(img->text[i].key, key) == 0)
            return img->text[i].value;
    return NULL;
}
