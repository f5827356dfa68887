/* PNG files through libpng: what `trioct render` writes, and what a check of a rendered
 * picture reads back, text chunks (the render's parameters) included. */
#ifndef TRIOCT_CLI_PNG_H
#define TRIOCT_CLI_PNG_H

#include <stddef.h>
#include <stdint.h>

#define CLI_PNG_MAX_TEXT 16

typedef struct cli_png_text {
    char key[80]; /* PNG keywords are 1-79 bytes */
    char value[256];
} cli_png_text;

/* An image of 16-bit samples: channels 2 (grey, alpha) or 4 (red, green, blue, alpha),
 * row 0 at the top. With bit_depth 8 only the low byte of each sample is written (and
 * read back there). */
typedef struct cli_png_image {
    int width, height, channels, bit_depth;
    uint16_t *samples; /* width * height * channels */
    cli_png_text text[CLI_PNG_MAX_TEXT];
    size_t num_text;
} cli_png_image;

/* Writes img to path. Returns 0, or -1 with why in err (a partly written file is removed). */
int cli_png_write(const char *path, const cli_png_image *img, char *err, size_t err_len);

/* Reads a grey-alpha or RGBA PNG of 8 or 16 bits into img (samples allocated; free them
 * with cli_png_image_free). Returns 0, or -1 with why in err. */
int cli_png_read(const char *path, cli_png_image *img, char *err, size_t err_len);

void cli_png_image_free(cli_png_image *img);

/* The value of a text chunk, or NULL. */
const char *cli_png_text_get(const cli_png_image *img, const char *key);

#endif
