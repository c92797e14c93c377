/* The EXIF orientation tag of a photo and turning the stored pixels upright by it. */
#ifndef ESR_IO_EXIF_H
#define ESR_IO_EXIF_H

#include <stddef.h>

#include "io/image.h"

/* The orientation (1..8, EXIF tag 0x0112 of IFD0) in the payload of a JPEG APP1 segment
 * ("Exif\0\0" + a TIFF structure, either byte order); 1 (upright) when the segment is not EXIF,
 * has no orientation tag, or is malformed. Reads only within the n bytes. */
int esr_exif_orientation(const unsigned char *app1, size_t n);

/* Applies an EXIF orientation to stored pixels: 2 mirror, 3 rotate 180, 4 flip, 5 transpose,
 * 6 rotate 90 clockwise, 7 transverse, 8 rotate 90 counter-clockwise (5-8 swap width and
 * height). *out is a new image; 1 or an unknown value copies. */
int esr_image_orient(const struct esr_image *in, int orientation, struct esr_image *out);

#endif
