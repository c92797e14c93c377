/* EXIF orientation (see exif.h): the TIFF header's byte order, IFD0's offset, and IFD0's
 * 12-byte entries (tag, type, count, value) searched for tag 0x0112, a SHORT stored in the
 * first two bytes of the value field. */
#include "io/exif.h"

#include <stdint.h>
#include <string.h>

#include "core/error.h"

static uint32_t load(const unsigned char *p, int bytes, int big_endian)
{
    uint32_t v = 0;
    for (int i = 0; i < bytes; i++)
        v |= (uint32_t)p[big_endian ? i : bytes - 1 - i] << (8 * (bytes - 1 - i));
    return v;
}

int esr_exif_orientation(const unsigned char *app1, size_t n)
{
    enum { TAG_ORIENTATION = 0x0112, TYPE_SHORT = 3 };
    if (n < 6 + 8 || memcmp(app1, "Exif\0\0", 6) != 0)
        return 1;
    const unsigned char *tiff = app1 + 6;
    size_t size = n - 6;
    int big;
    if (!memcmp(tiff, "MM\0*", 4))
        big = 1;
    else if (!memcmp(tiff, "II*\0", 4))
        big = 0;
    else
        return 1;
    uint32_t ifd = load(tiff + 4, 4, big);
    if (ifd > size - 2)
        return 1;
    uint32_t entries = load(tiff + ifd, 2, big);
    for (uint32_t e = 0; e < entries; e++) {
        size_t at = ifd + 2 + (size_t)e * 12;
        if (at + 12 > size)
            return 1;
        const unsigned char *entry = tiff + at;
        if (load(entry, 2, big) != TAG_ORIENTATION)
            continue;
        uint32_t value = load(entry + 8, 2, big);
        int ok = load(entry + 2, 2, big) == TYPE_SHORT && value >= 1 && value <= 8;
        return ok ? (int)value : 1;
    }
    return 1;
}

int esr_image_orient(const struct esr_image *in, int orientation, struct esr_image *out)
{
    /* Per orientation: whether output (x, y) reads stored (y, x), then mirrors of the stored
     * column and row. */
    static const struct {
        unsigned char swap, flip_x, flip_y;
    } table[9] = {{0, 0, 0}, {0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1},
                  {1, 0, 0}, {1, 0, 1}, {1, 1, 1}, {1, 1, 0}};
    if (orientation < 1 || orientation > 8)
        orientation = 1;
    const int swap = table[orientation].swap;
    const int w = swap ? in->height : in->width, h = swap ? in->width : in->height;
    ESR_TRY(esr_image_alloc(out, w, h, in->channels));
    const int c = in->channels;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int sx = swap ? y : x, sy = swap ? x : y;
            if (table[orientation].flip_x)
                sx = in->width - 1 - sx;
            if (table[orientation].flip_y)
                sy = in->height - 1 - sy;
            memcpy(out->data + ((size_t)y * (size_t)w + (size_t)x) * (size_t)c,
                   in->data + ((size_t)sy * (size_t)in->width + (size_t)sx) * (size_t)c, (size_t)c * sizeof(float));
        }
    return ESR_OK;
}
