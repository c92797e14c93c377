#include "io/exif_exposure.h"

#include <cJSON.h>

#include <libexif/exif-data.h>
#include <libexif/exif-utils.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

int esr_exif_exposure_check(const struct esr_exif_exposure *e, char *why, size_t why_size)
{
    if (!(e->exposure_time_s > 0.0 && e->exposure_time_s <= 3600.0)) {
        snprintf(why, why_size, "ExposureTime %g s is absurd", e->exposure_time_s);
        return -1;
    }
    if (!(e->f_number >= 0.5 && e->f_number <= 128.0)) {
        snprintf(why, why_size, "FNumber %g is absurd", e->f_number);
        return -1;
    }
    if (e->iso <= 0 || e->iso > 1000000) {
        snprintf(why, why_size, "ISO %d is absurd", e->iso);
        return -1;
    }
    return 0;
}

cJSON *esr_exif_exposure_json(const struct esr_exif_exposure *e)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "exposure_time_s", e->exposure_time_s);
    cJSON_AddNumberToObject(j, "f_number", e->f_number);
    cJSON_AddNumberToObject(j, "iso", e->iso);
    return j;
}

double esr_exif_relative_exposure(const struct esr_exif_exposure *e)
{
    return e->exposure_time_s * (double)e->iso / (e->f_number * e->f_number);
}

/* v as a rational with denominator den (rounded), the form EXIF stores exposure times in. */
static ExifRational rational(double v, ExifLong den)
{
    ExifRational r = {(ExifLong)llround(v * (double)den), den};
    return r;
}

/* An entry of tag in the EXIF IFD, initialised by libexif (format and size of the tag). */
static ExifEntry *new_entry(ExifData *d, ExifTag tag)
{
    ExifEntry *entry = exif_entry_new();
    if (!entry)
        return NULL;
    exif_content_add_entry(d->ifd[EXIF_IFD_EXIF], entry);
    exif_entry_initialize(entry, tag);
    exif_entry_unref(entry); /* the IFD holds it */
    return entry;
}

int esr_exif_exposure_payload(const struct esr_exif_exposure *e, unsigned char **out, size_t *size)
{
    *out = NULL;
    *size = 0;
    ExifData *d = exif_data_new();
    if (!d)
        return ESR_FAIL("out of memory for EXIF data");
    exif_data_set_byte_order(d, EXIF_BYTE_ORDER_INTEL);
    const ExifByteOrder order = exif_data_get_byte_order(d);
    ExifEntry *t = new_entry(d, EXIF_TAG_EXPOSURE_TIME), *f = new_entry(d, EXIF_TAG_FNUMBER),
              *iso = new_entry(d, EXIF_TAG_ISO_SPEED_RATINGS);
    int rc = ESR_OK;
    if (!t || !f || !iso || !t->data || !f->data || !iso->data)
        rc = ESR_FAIL("out of memory for EXIF entries");
    else {
        /* microsecond exposure times: 2% is far coarser than the rounding for any t >= 1/20000 s */
        exif_set_rational(t->data, order, rational(e->exposure_time_s, 1000000));
        exif_set_rational(f->data, order, rational(e->f_number, 100));
        exif_set_short(iso->data, order, (ExifShort)e->iso);
        unsigned char *buf = NULL;
        unsigned int n = 0;
        exif_data_save_data(d, &buf, &n);
        if (!buf || n == 0)
            rc = ESR_FAIL("libexif could not write the EXIF data");
        else {
            *out = malloc(n);
            if (*out) {
                memcpy(*out, buf, n);
                *size = n;
            } else
                rc = ESR_FAIL("out of memory for EXIF data");
            free(buf);
        }
    }
    exif_data_unref(d);
    return rc;
}

/* A rational tag's value, or NaN when the tag is missing, not one rational, or has denominator 0. */
static double read_rational(ExifData *d, ExifTag tag, ExifByteOrder order)
{
    ExifEntry *entry = exif_data_get_entry(d, tag);
    if (!entry || entry->format != EXIF_FORMAT_RATIONAL || entry->components < 1 || entry->size < 8)
        return NAN;
    const ExifRational r = exif_get_rational(entry->data, order);
    return r.denominator ? (double)r.numerator / (double)r.denominator : NAN;
}

int esr_exif_exposure_read(const unsigned char *data, size_t n, struct esr_exif_exposure *e, char *why,
                           size_t why_size)
{
    if (why_size)
        why[0] = 0;
    ExifData *d = n <= 0xffffffffu ? exif_data_new_from_data(data, (unsigned int)n) : NULL;
    if (!d)
        return 0;
    const ExifByteOrder order = exif_data_get_byte_order(d);
    const double t = read_rational(d, EXIF_TAG_EXPOSURE_TIME, order), f = read_rational(d, EXIF_TAG_FNUMBER, order);
    ExifEntry *iso = exif_data_get_entry(d, EXIF_TAG_ISO_SPEED_RATINGS);
    const int have_iso = iso && iso->format == EXIF_FORMAT_SHORT && iso->components >= 1 && iso->size >= 2;
    const long iso_value = have_iso ? (long)exif_get_short(iso->data, order) : 0;
    const int present = exif_data_get_entry(d, EXIF_TAG_EXPOSURE_TIME) && exif_data_get_entry(d, EXIF_TAG_FNUMBER) &&
                        have_iso;
    exif_data_unref(d);
    if (!present)
        return 0;
    const struct esr_exif_exposure found = {t, f, (int)iso_value};
    if (esr_exif_exposure_check(&found, why, why_size) != 0)
        return -1;
    *e = found;
    return 1;
}
