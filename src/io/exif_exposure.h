/* A photo's EXIF exposure (ExposureTime, FNumber, ISO) made and read through libexif. */
#ifndef ESR_IO_EXIF_EXPOSURE_H
#define ESR_IO_EXIF_EXPOSURE_H

#include <stddef.h>

struct esr_exif_exposure {
    double exposure_time_s; /* ExposureTime, seconds */
    double f_number;        /* FNumber */
    int iso;                /* ISOSpeedRatings */
};

/* 0 when e is plausible; -1 when any value is absurd (exposure time not in (0, 3600] s, f-number
 * not in [0.5, 128], ISO 0 or over 10^6), with *why saying which (why_size bytes). */
int esr_exif_exposure_check(const struct esr_exif_exposure *e, char *why, size_t why_size);

/* e as the dataset's frames record it: {"exposure_time_s", "f_number", "iso"} (a new object). */
struct cJSON;
struct cJSON *esr_exif_exposure_json(const struct esr_exif_exposure *e);

/* The light a sensor records, relative: exposure_time_s * iso / f_number^2. */
double esr_exif_relative_exposure(const struct esr_exif_exposure *e);

/* The APP1 payload ("Exif\0\0" + TIFF) holding e's three tags, into *out (free() it). */
int esr_exif_exposure_payload(const struct esr_exif_exposure *e, unsigned char **out, size_t *size);

/* The three tags from an APP1 payload (or a whole JPEG file's bytes): 1 with *e filled when all
 * three are there and plausible; 0 when any is missing; -1 when any is absurd (exposure time
 * not in (0, 3600] s, f-number not in [0.5, 128], ISO 0 or over 10^6), with *why saying which
 * (why_size bytes). Never trusts a value it did not check. */
int esr_exif_exposure_read(const unsigned char *data, size_t n, struct esr_exif_exposure *e, char *why,
                           size_t why_size);

#endif
