/* EXR files through the OpenEXRCore C API. OpenEXR only moves stored bytes: every channel is
 * decoded into (or encoded from) its own contiguous plane in its stored type, and esr converts
 * and interleaves itself. Decoding half channels straight into an interleaved RGBA buffer swaps
 * channels in OpenEXR 3.1.5, and planes of the native type avoid every conversion path. */
#include <OpenEXR/openexr.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/limits.h"
#include "io/file.h"
#include "io/half.h"
#include "io/image.h"

/* OpenEXR reports details through a callback (default: print to stderr, which the library must
 * never do); keep the latest message so the failing call can quote it. */
static _Thread_local char exr_detail[512];

static void exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_detail, sizeof exr_detail, "%s", msg ? msg : exr_get_default_error_message(code));
}

static const char *exr_message(exr_result_t rc)
{
    return exr_detail[0] ? exr_detail : exr_get_default_error_message(rc);
}

static float exr_sample_to_float(const uint8_t *p, uint16_t type)
{
    if (type == EXR_PIXEL_HALF) {
        uint16_t h;
        memcpy(&h, p, sizeof h);
        return esr_half_to_float(h);
    }
    if (type == EXR_PIXEL_UINT) {
        uint32_t u;
        memcpy(&u, p, sizeof u);
        return (float)u;
    }
    float f;
    memcpy(&f, p, sizeof f);
    return f;
}

static size_t exr_type_size(int type) { return type == EXR_PIXEL_HALF ? 2 : 4; }

/* Output channel (0..3 = R,G,B,A) a stored channel feeds; 4 for a luminance-only "Y"; -1 = ignored.
 * With a layer, only the layer's channels "<layer>.R" and so on feed one. */
static int exr_channel_slot(const char *layer, const char *name)
{
    if (layer) {
        const size_t n = strlen(layer);
        if (strncmp(name, layer, n) || name[n] != '.')
            return -1;
        name += n + 1;
    }
    static const char *const names[5] = {"R", "G", "B", "A", "Y"};
    for (int k = 0; k < 5; k++)
        if (!strcmp(name, names[k]))
            return k;
    return -1;
}

struct exr_reader {
    exr_context_t ctx;
    exr_attr_box2i_t window; /* data window */
    exr_decode_pipeline_t decoder;
    int decoder_ready;
    uint8_t *planes[5]; /* one chunk's samples per output slot, stored type */
    struct esr_image *out;
    const char *layer; /* NULL: the bare channels; else the layer's (esr_exr_read_layer) */
};

/* Decodes one chunk into the planes and scatters it into the RGBA output. */
static int read_chunk(struct exr_reader *r, const exr_chunk_info_t *cinfo, const char *path)
{
    exr_result_t rc = r->decoder_ready ? exr_decoding_update(r->ctx, 0, cinfo, &r->decoder)
                                       : exr_decoding_initialize(r->ctx, 0, cinfo, &r->decoder);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("'%s': corrupt EXR chunk at y=%d: %s", path, cinfo->start_y, exr_message(rc));
    r->decoder_ready = 1;
    uint16_t types[5] = {0};
    int present[5] = {0};
    for (int c = 0; c < r->decoder.channel_count; c++) {
        exr_coding_channel_info_t *ch = &r->decoder.channels[c];
        int slot = exr_channel_slot(r->layer, ch->channel_name);
        if (slot < 0) {
            ch->decode_to_ptr = NULL;
            continue;
        }
        types[slot] = ch->data_type;
        present[slot] = 1;
        ch->user_bytes_per_element = ch->bytes_per_element;
        ch->user_data_type = ch->data_type;
        ch->user_pixel_stride = ch->bytes_per_element;
        ch->user_line_stride = ch->bytes_per_element * cinfo->width;
        ch->decode_to_ptr = r->planes[slot];
    }
    rc = exr_decoding_choose_default_routines(r->ctx, 0, &r->decoder);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_decoding_run(r->ctx, 0, &r->decoder);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("'%s': corrupt EXR chunk at y=%d: %s", path, cinfo->start_y, exr_message(rc));
    /* Y first, so that R, G, B win when a file has both. */
    static const int order[5] = {4, 0, 1, 2, 3};
    struct esr_image *out = r->out;
    for (int y = 0; y < cinfo->height; y++)
        for (int x = 0; x < cinfo->width; x++) {
            size_t src = (size_t)y * (size_t)cinfo->width + (size_t)x;
            size_t dst = ((size_t)(cinfo->start_y - r->window.min.y + y) * (size_t)out->width +
                          (size_t)(cinfo->start_x - r->window.min.x + x)) * 4;
            for (int i = 0; i < 5; i++) {
                int slot = order[i];
                if (!present[slot])
                    continue;
                float v = exr_sample_to_float(r->planes[slot] + src * exr_type_size(types[slot]), types[slot]);
                if (slot == 4)
                    out->data[dst] = out->data[dst + 1] = out->data[dst + 2] = v;
                else
                    out->data[dst + (size_t)slot] = v;
            }
        }
    return ESR_OK;
}

/* Reads every chunk of part 0 (scanline, or level 0 of a tiled part). */
static int read_chunks(struct exr_reader *r, exr_storage_t storage, const char *path)
{
    int w = r->out->width, h = r->out->height;
    exr_chunk_info_t cinfo;
    exr_result_t rc;
    if (storage == EXR_STORAGE_SCANLINE) {
        int32_t lines;
        rc = exr_get_scanlines_per_chunk(r->ctx, 0, &lines);
        if (rc != EXR_ERR_SUCCESS || lines <= 0)
            return ESR_FAIL("'%s': bad EXR header: %s", path, exr_message(rc));
        for (int y = r->window.min.y; y <= r->window.max.y; y += lines) {
            rc = exr_read_scanline_chunk_info(r->ctx, 0, y, &cinfo);
            if (rc != EXR_ERR_SUCCESS)
                return ESR_FAIL("'%s': truncated or corrupt EXR (scanline %d): %s", path, y, exr_message(rc));
            ESR_TRY(read_chunk(r, &cinfo, path));
        }
        return ESR_OK;
    }
    uint32_t tw, th;
    exr_tile_level_mode_t level;
    exr_tile_round_mode_t round;
    rc = exr_get_tile_descriptor(r->ctx, 0, &tw, &th, &level, &round);
    if (rc != EXR_ERR_SUCCESS || tw == 0 || th == 0)
        return ESR_FAIL("'%s': bad EXR tile description: %s", path, exr_message(rc));
    for (int ty = 0; ty < (int)((h + th - 1) / th); ty++)
        for (int tx = 0; tx < (int)((w + tw - 1) / tw); tx++) {
            rc = exr_read_tile_chunk_info(r->ctx, 0, tx, ty, 0, 0, &cinfo);
            if (rc != EXR_ERR_SUCCESS)
                return ESR_FAIL("'%s': truncated or corrupt EXR (tile %d,%d): %s", path, tx, ty, exr_message(rc));
            ESR_TRY(read_chunk(r, &cinfo, path));
        }
    return ESR_OK;
}

/* Validates the header of part 0 and prepares the reader (output image, per-slot planes). */
static int exr_read_setup(struct exr_reader *r, exr_storage_t *storage, const char *path)
{
    exr_result_t rc = exr_get_storage(r->ctx, 0, storage);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("'%s': bad EXR header: %s", path, exr_message(rc));
    if (*storage != EXR_STORAGE_SCANLINE && *storage != EXR_STORAGE_TILED)
        return ESR_FAIL("'%s': deep EXR images are not supported", path);
    rc = exr_get_data_window(r->ctx, 0, &r->window);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("'%s': bad EXR data window: %s", path, exr_message(rc));
    int64_t w = (int64_t)r->window.max.x - r->window.min.x + 1, h = (int64_t)r->window.max.y - r->window.min.y + 1;
    if (w <= 0 || h <= 0)
        return ESR_FAIL("'%s': unsupported EXR size %lldx%lld", path, (long long)w, (long long)h);
    /* refused before anything is allocated for the claimed size */
    if ((uint64_t)w * (uint64_t)h > esr_limits()->image_pixels)
        return ESR_FAIL("'%s': EXR claims %lldx%lld pixels, more than the %zu esr reads", path, (long long)w,
                        (long long)h, esr_limits()->image_pixels);
    const exr_attr_chlist_t *chlist;
    rc = exr_get_channels(r->ctx, 0, &chlist);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("'%s': bad EXR channel list: %s", path, exr_message(rc));
    int colour = 0;
    for (int c = 0; c < chlist->num_channels; c++) {
        const exr_attr_chlist_entry_t *e = &chlist->entries[c];
        int slot = exr_channel_slot(r->layer, e->name.str);
        if (slot < 0)
            continue;
        if (e->x_sampling != 1 || e->y_sampling != 1)
            return ESR_FAIL("'%s': subsampled EXR channel '%s' is not supported", path, e->name.str);
        colour |= slot != 3;
    }
    if (!colour && r->layer)
        return ESR_FAIL("'%s': EXR has no layer '%s' (none of its channels %s.R, .G, .B or .Y)",
                        path, r->layer, r->layer);
    if (!colour)
        return ESR_FAIL("'%s': EXR has none of the channels R, G, B or Y", path);
    /* A chunk never reaches past the data window, so a header's huge tile costs no more than
     * the image. */
    int64_t cw = w, ch;
    if (*storage == EXR_STORAGE_SCANLINE) {
        int32_t lines;
        if (exr_get_scanlines_per_chunk(r->ctx, 0, &lines) != EXR_ERR_SUCCESS || lines <= 0 || lines > 256)
            return ESR_FAIL("'%s': bad EXR scanlines per chunk", path);
        ch = lines;
    } else {
        uint32_t tw, th;
        exr_tile_level_mode_t level;
        exr_tile_round_mode_t round;
        if (exr_get_tile_descriptor(r->ctx, 0, &tw, &th, &level, &round) != EXR_ERR_SUCCESS || !tw || !th)
            return ESR_FAIL("'%s': bad EXR tile description", path);
        cw = tw < w ? tw : w;
        ch = th;
    }
    const int64_t chunk_pixels = cw * (ch < h ? ch : h);
    for (int c = 0; c < chlist->num_channels; c++) {
        int slot = exr_channel_slot(r->layer, chlist->entries[c].name.str);
        if (slot >= 0 && !r->planes[slot] && !(r->planes[slot] = malloc((size_t)chunk_pixels * 4)))
            return ESR_FAIL("out of memory reading '%s'", path);
    }
    ESR_TRY(esr_image_alloc(r->out, (int)w, (int)h, 4));
    /* Missing alpha means opaque. */
    for (size_t p = 0; p < (size_t)(w * h); p++)
        r->out->data[p * 4 + 3] = 1.0f;
    return ESR_OK;
}

/* The file's bytes in memory, read by OpenEXR through exr_memory_read (pread semantics). */
struct exr_source {
    const uint8_t *data;
    size_t size;
};

static int64_t exr_memory_read(exr_const_context_t ctxt, void *user, void *buffer, uint64_t sz, uint64_t offset,
                               exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    const struct exr_source *src = user;
    if (offset >= src->size)
        return 0;
    size_t n = sz < src->size - offset ? (size_t)sz : src->size - (size_t)offset;
    memcpy(buffer, src->data + offset, n);
    return (int64_t)n;
}

static int64_t exr_memory_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    return (int64_t)((const struct exr_source *)user)->size;
}

static int exr_decode_layer(const void *bytes, size_t size, const char *name, const char *layer,
                            struct esr_image *out)
{
    memset(out, 0, sizeof *out);
    struct exr_source src = {bytes, size};
    struct exr_reader r;
    memset(&r, 0, sizeof r);
    r.out = out;
    r.layer = layer;
    exr_detail[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    init.user_data = &src;
    init.read_fn = exr_memory_read;
    init.size_fn = exr_memory_size;
    exr_result_t rc = exr_start_read(&r.ctx, name, &init);
    int status;
    if (rc != EXR_ERR_SUCCESS) {
        status = ESR_FAIL("'%s' is not a readable EXR: %s", name, exr_message(rc));
    } else {
        exr_storage_t storage;
        status = exr_read_setup(&r, &storage, name);
        if (status == ESR_OK)
            status = read_chunks(&r, storage, name);
    }
    if (r.decoder_ready)
        exr_decoding_destroy(r.ctx, &r.decoder);
    if (r.ctx)
        exr_finish(&r.ctx);
    for (int k = 0; k < 5; k++)
        free(r.planes[k]);
    if (status != ESR_OK)
        esr_image_free(out);
    return status;
}

int esr_exr_decode(const void *bytes, size_t size, const char *name, struct esr_image *out)
{
    return exr_decode_layer(bytes, size, name, NULL, out);
}

int esr_exr_read_layer(const char *path, const char *layer, struct esr_image *out)
{
    memset(out, 0, sizeof *out);
    unsigned char *bytes;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &bytes, &size));
    int status = exr_decode_layer(bytes, size, path, layer, out);
    free(bytes);
    return status;
}

int esr_exr_read(const char *path, struct esr_image *out)
{
    return esr_exr_read_layer(path, NULL, out);
}

/* ---- writing ---- */

/* The encoder writes into memory (at arbitrary offsets: the chunk table is patched last); the
 * bytes then go to disk through esr_file_write_atomic. */
struct exr_memory {
    uint8_t *data;
    size_t size, capacity;
    int failed;
};

static int64_t exr_memory_write(exr_const_context_t ctxt, void *user, const void *buffer, uint64_t sz,
                                uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    struct exr_memory *m = user;
    size_t end = (size_t)(offset + sz);
    if (end > m->capacity) {
        size_t cap = m->capacity ? m->capacity : 1 << 16;
        while (cap < end)
            cap *= 2;
        uint8_t *grown = realloc(m->data, cap);
        if (!grown) {
            m->failed = 1;
            return -1;
        }
        memset(grown + m->capacity, 0, cap - m->capacity);
        m->data = grown;
        m->capacity = cap;
    }
    memcpy(m->data + offset, buffer, (size_t)sz);
    if (end > m->size)
        m->size = end;
    return (int64_t)sz;
}

static const char *const exr_names_by_channels[5][4] = {
    {NULL}, {"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};

/* Image channel k converted into one plane of the stored type. */
static uint8_t *exr_make_plane(const struct esr_image *img, int k, exr_pixel_type_t type)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    uint8_t *plane = malloc(n * exr_type_size(type));
    if (!plane)
        return NULL;
    for (size_t p = 0; p < n; p++) {
        float v = img->data[p * (size_t)img->channels + (size_t)k];
        if (type == EXR_PIXEL_HALF) {
            uint16_t h = esr_float_to_half(v);
            memcpy(plane + p * 2, &h, 2);
        } else if (type == EXR_PIXEL_UINT) {
            uint32_t u = v > 0.0f ? (v < 4294967040.0f ? (uint32_t)lrintf(v) : UINT32_MAX) : 0u;
            memcpy(plane + p * 4, &u, 4);
        } else {
            memcpy(plane + p * 4, &v, 4);
        }
    }
    return plane;
}

/* The most layers one file holds (esr_exr_write_layers) and the longest layer name. */
#define EXR_MAX_LAYERS 64
#define EXR_LAYER_NAME_MAX 64

/* What one file is written from: n layers of one size and channel count, stored channel j of
 * layer l named "<names[l]>.<R|G|B|A|Y>" (no names: the bare channel names). */
struct exr_layers_in {
    const struct esr_image *layers;
    const char *const *names;
    int n;
};

struct exr_writer {
    exr_context_t ctx;
    exr_encode_pipeline_t encoder;
    int encoder_ready;
    uint8_t *planes[EXR_MAX_LAYERS * 4];
    char channel_names[EXR_MAX_LAYERS * 4][EXR_LAYER_NAME_MAX + 3];
    int n_planes;
    exr_result_t (*library_compress)(exr_encode_pipeline_t *encode);
};

/* OpenEXR 3.1.5 keeps compressed output that is exactly as long as the raw chunk, but readers
 * take a chunk of that length as stored uncompressed (and decode garbage). Store such chunks raw. */
static exr_result_t exr_compress_or_store(exr_encode_pipeline_t *encode)
{
    const struct exr_writer *wr = encode->encoding_user_data;
    exr_result_t rc = wr->library_compress(encode);
    if (rc == EXR_ERR_SUCCESS && encode->compressed_bytes >= encode->packed_bytes &&
        encode->compressed_buffer != encode->packed_buffer) {
        memcpy(encode->compressed_buffer, encode->packed_buffer, (size_t)encode->packed_bytes);
        encode->compressed_bytes = (size_t)encode->packed_bytes;
    }
    return rc;
}

static int exr_write_chunks(struct exr_writer *wr, const struct esr_image *img, exr_pixel_type_t type,
                            const char *path)
{
    int32_t lines;
    exr_result_t rc = exr_get_scanlines_per_chunk(wr->ctx, 0, &lines);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("cannot encode '%s': %s", path, exr_message(rc));
    size_t bpe = exr_type_size(type);
    for (int y = 0; y < img->height; y += lines) {
        exr_chunk_info_t cinfo;
        rc = exr_write_scanline_chunk_info(wr->ctx, 0, y, &cinfo);
        if (rc == EXR_ERR_SUCCESS)
            rc = wr->encoder_ready ? exr_encoding_update(wr->ctx, 0, &cinfo, &wr->encoder)
                                   : exr_encoding_initialize(wr->ctx, 0, &cinfo, &wr->encoder);
        if (rc != EXR_ERR_SUCCESS)
            return ESR_FAIL("cannot encode '%s': %s", path, exr_message(rc));
        wr->encoder_ready = 1;
        for (int c = 0; c < wr->encoder.channel_count; c++) {
            exr_coding_channel_info_t *ch = &wr->encoder.channels[c];
            int k = 0; /* the header sorts the channels by name: find each one's plane */
            while (k < wr->n_planes - 1 && strcmp(ch->channel_name, wr->channel_names[k]))
                k++;
            ch->user_bytes_per_element = (int16_t)bpe;
            ch->user_data_type = (uint16_t)type;
            ch->user_pixel_stride = (int32_t)bpe;
            ch->user_line_stride = (int32_t)bpe * img->width;
            ch->encode_from_ptr = wr->planes[k] + (size_t)y * (size_t)img->width * bpe;
        }
        rc = exr_encoding_choose_default_routines(wr->ctx, 0, &wr->encoder);
        if (rc == EXR_ERR_SUCCESS && wr->encoder.compress_fn) {
            wr->library_compress = wr->encoder.compress_fn;
            wr->encoder.compress_fn = exr_compress_or_store;
            wr->encoder.encoding_user_data = wr;
        }
        if (rc == EXR_ERR_SUCCESS)
            rc = exr_encoding_run(wr->ctx, 0, &wr->encoder);
        if (rc != EXR_ERR_SUCCESS)
            return ESR_FAIL("cannot encode '%s': %s", path, exr_message(rc));
    }
    return ESR_OK;
}

static int write_header(struct exr_writer *wr, const struct esr_image *img, exr_pixel_type_t type,
                        exr_compression_t compression, const char *path)
{
    int part;
    exr_result_t rc = exr_add_part(wr->ctx, "rgba", EXR_STORAGE_SCANLINE, &part);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_initialize_required_attr_simple(wr->ctx, part, img->width, img->height, compression);
    for (int k = 0; k < wr->n_planes && rc == EXR_ERR_SUCCESS; k++)
        rc = exr_add_channel(wr->ctx, part, wr->channel_names[k], type,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_write_header(wr->ctx);
    if (rc != EXR_ERR_SUCCESS)
        return ESR_FAIL("cannot write the EXR header of '%s': %s", path, exr_message(rc));
    return ESR_OK;
}

/* Whether src can be written: its layers of one size and 1..4 channels, named (when named) with
 * letters, digits and _ only. */
static int exr_source_check(const struct exr_layers_in *src, const char *path)
{
    const struct esr_image *img = &src->layers[0];
    if (src->n < 1 || src->n > EXR_MAX_LAYERS || (src->n > 1 && !src->names))
        return ESR_FAIL("cannot write '%s': %d layers (1 to %d, named when more than one)", path,
                        src->n, EXR_MAX_LAYERS);
    for (int l = 0; l < src->n; l++) {
        const struct esr_image *li = &src->layers[l];
        if (!li->data || li->width <= 0 || li->height <= 0 || li->channels < 1 || li->channels > 4 ||
            li->width != img->width || li->height != img->height || li->channels != img->channels)
            return ESR_FAIL("cannot write '%s': invalid image (%dx%d, %d channels)", path, li->width,
                            li->height, li->channels);
        const char *name = src->names ? src->names[l] : NULL;
        size_t len = name ? strlen(name) : 0;
        int ok = !name || (len > 0 && len <= EXR_LAYER_NAME_MAX);
        for (size_t i = 0; ok && i < len; i++)
            ok = (name[i] >= 'a' && name[i] <= 'z') || (name[i] >= 'A' && name[i] <= 'Z') ||
                 (name[i] >= '0' && name[i] <= '9') || name[i] == '_';
        if (!ok)
            return ESR_FAIL("cannot write '%s': layer name '%s' (1 to %d letters, digits or _)",
                            path, name, EXR_LAYER_NAME_MAX);
    }
    return ESR_OK;
}

static int exr_write_source(const char *path, const struct exr_layers_in *src,
                            enum esr_exr_pixel pixel, enum esr_exr_compression compression)
{
    static const exr_pixel_type_t types[3] = {EXR_PIXEL_HALF, EXR_PIXEL_FLOAT, EXR_PIXEL_UINT};
    static const exr_compression_t codecs[5] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_RLE, EXR_COMPRESSION_ZIPS,
                                                EXR_COMPRESSION_ZIP, EXR_COMPRESSION_PIZ};
    if ((unsigned)pixel > 2u || (unsigned)compression > 4u)
        return ESR_FAIL("cannot write '%s': unknown EXR pixel type or compression", path);
    ESR_TRY(exr_source_check(src, path));
    const struct esr_image *img = &src->layers[0];
    exr_pixel_type_t type = types[pixel];
    struct exr_writer *wr = calloc(1, sizeof *wr);
    if (!wr)
        return ESR_FAIL("out of memory encoding '%s'", path);
    struct exr_memory mem = {NULL, 0, 0, 0};
    int status = ESR_OK;
    for (int l = 0; l < src->n && status == ESR_OK; l++)
        for (int k = 0; k < img->channels && status == ESR_OK; k++) {
            const char *channel = exr_names_by_channels[img->channels][k];
            if (src->names)
                snprintf(wr->channel_names[wr->n_planes], sizeof wr->channel_names[0], "%s.%s",
                         src->names[l], channel);
            else
                snprintf(wr->channel_names[wr->n_planes], sizeof wr->channel_names[0], "%s", channel);
            if (!(wr->planes[wr->n_planes++] = exr_make_plane(&src->layers[l], k, type)))
                status = ESR_FAIL("out of memory encoding '%s'", path);
        }
    exr_detail[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    init.user_data = &mem;
    init.write_fn = exr_memory_write;
    if (status == ESR_OK) {
        exr_result_t rc = exr_start_write(&wr->ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
        if (rc != EXR_ERR_SUCCESS)
            status = ESR_FAIL("cannot start writing '%s': %s", path, exr_message(rc));
    }
    if (status == ESR_OK)
        status = write_header(wr, img, type, codecs[compression], path);
    if (status == ESR_OK)
        status = exr_write_chunks(wr, img, type, path);
    if (wr->encoder_ready)
        exr_encoding_destroy(wr->ctx, &wr->encoder);
    if (wr->ctx) {
        exr_result_t rc = exr_finish(&wr->ctx);
        if (status == ESR_OK && (rc != EXR_ERR_SUCCESS || mem.failed))
            status = ESR_FAIL("cannot finish '%s': %s", path, mem.failed ? "out of memory" : exr_message(rc));
    }
    if (status == ESR_OK)
        status = esr_file_write_atomic(path, mem.data, mem.size);
    free(mem.data);
    for (int k = 0; k < wr->n_planes; k++)
        free(wr->planes[k]);
    free(wr);
    return status;
}

int esr_exr_write_as(const char *path, const struct esr_image *img, enum esr_exr_pixel pixel,
                     enum esr_exr_compression compression)
{
    const struct exr_layers_in src = {img, NULL, 1};
    return exr_write_source(path, &src, pixel, compression);
}

int esr_exr_write_layers(const char *path, const struct esr_image *layers,
                         const char *const *names, int n, enum esr_exr_pixel pixel,
                         enum esr_exr_compression compression)
{
    if (!layers || !names)
        return ESR_FAIL("cannot write '%s': no layers", path);
    const struct exr_layers_in src = {layers, names, n};
    return exr_write_source(path, &src, pixel, compression);
}

int esr_exr_write(const char *path, const struct esr_image *img, int half)
{
    return esr_exr_write_as(path, img, half ? ESR_EXR_HALF : ESR_EXR_FLOAT, ESR_EXR_ZIP);
}
