/* The 3x5 digit font (digit_font.h). */
#include "render/digit_font.h"

#include <stdio.h>

/* rows top first, bit 2 = left column */
static const unsigned char glyph[10][5] = {
    {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
    {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7},
};

static int count_digits(int n)
{
    int d = 1;
    while (n >= 10)
        n /= 10, d++;
    return d;
}

void esr_digits_size(int n, int s, int *width, int *height)
{
    const int d = count_digits(n < 0 ? 0 : n);
    *width = (d * 4 + 1) * s; /* 3 wide + 1 gap each, margins 1 left (the last gap) and 1 right */
    *height = 7 * s;
}

static void put(struct esr_image *img, int x, int y, const float rgb[3])
{
    if (x < 0 || y < 0 || x >= img->width || y >= img->height || img->channels < 3)
        return;
    float *p = img->data + ((size_t)y * (size_t)img->width + (size_t)x) * (size_t)img->channels;
    p[0] = rgb[0], p[1] = rgb[1], p[2] = rgb[2];
    if (img->channels == 4)
        p[3] = 1.0f;
}

void esr_digits_draw(struct esr_image *img, int x, int y, int n, int s, const float fg[3],
                     const float bg[3])
{
    if (n < 0)
        n = 0;
    int w, h;
    esr_digits_size(n, s, &w, &h);
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++)
            put(img, x + i, y + j, bg);
    char text[16];
    snprintf(text, sizeof text, "%d", n);
    for (int k = 0; text[k]; k++) {
        const unsigned char *g = glyph[text[k] - '0'];
        const int gx = x + (1 + 4 * k) * s, gy = y + s;
        for (int row = 0; row < 5; row++)
            for (int col = 0; col < 3; col++)
                if (g[row] & (4 >> col))
                    for (int j = 0; j < s; j++)
                        for (int i = 0; i < s; i++)
                            put(img, gx + col * s + i, gy + row * s + j, fg);
    }
}
