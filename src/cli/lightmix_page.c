/* The LightMix page's files (see lightmix_page.h). */
#include "cli/lightmix_page.h"

#include <cjson/cJSON.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/file.h"
#include "io/half.h"
#include "io/json_file.h"

extern const char esr_lightmix_page_html[];
extern const unsigned long esr_lightmix_page_html_size;

/* n bytes as base64 into out (4 * ceil(n / 3) characters and a NUL). */
static void base64(const uint8_t *in, size_t n, char *out)
{
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        const uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) |
                           (i + 2 < n ? in[i + 2] : 0);
        out[o++] = abc[v >> 18 & 63];
        out[o++] = abc[v >> 12 & 63];
        out[o++] = i + 1 < n ? abc[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? abc[v & 63] : '=';
    }
    out[o] = '\0';
}

int lightmix_page_view(const char *dir, const char *name, const struct esr_relight_layers *L)
{
    const int depth = 1 + 2 * L->n_lights, w = L->off.width, h = L->off.height;
    const size_t per = (size_t)w * (size_t)h * 3, bytes = (size_t)depth * per * 2;
    uint16_t *half = malloc(bytes);
    /* the half floats deflated (zlib; the page inflates them with the browser's
     * DecompressionStream): 4-5x smaller, so a 36-view orbit of 8 lights at 256 px stays under
     * 100 MB where the raw layers take 320 */
    uLongf packed = compressBound((uLong)bytes);
    uint8_t *zbuf = malloc(packed);
    const size_t cap = ((size_t)packed + 2) / 3 * 4 + 1 + ESR_NAME_MAX + 64;
    char *text = malloc(cap);
    if (!half || !zbuf || !text) {
        free(half), free(zbuf), free(text);
        return ESR_FAIL("lightmix: out of memory for the page's layers of %s", name);
    }
    for (int l = 0; l < depth; l++) {
        const float *src = l == 0 ? L->off.data : (l % 2 ? L->light[(l - 1) / 2].data
                                                         : L->value[(l - 1) / 2].data);
        for (size_t i = 0; i < per; i++) { /* little-endian, as typed arrays on every browser's host */
            const uint16_t v = esr_float_to_half(src[i]);
            memcpy((uint8_t *)half + ((size_t)l * per + i) * 2, (const uint8_t[2]){v & 0xff, v >> 8}, 2);
        }
    }
    if (compress2(zbuf, &packed, (const Bytef *)half, (uLong)bytes, 6) != Z_OK) {
        free(half), free(zbuf), free(text);
        return ESR_FAIL("lightmix: cannot deflate the page's layers of %s", name);
    }
    int len = snprintf(text, cap, "LIGHTMIX_VIEW(\"%s\", %d, %d, \"", name, w, h);
    base64(zbuf, (size_t)packed, text + len);
    len += (int)strlen(text + len);
    len += snprintf(text + len, cap - (size_t)len, "\", \"deflate\");\n");
    char path[4400];
    snprintf(path, sizeof path, "%s/%s.js", dir, name);
    const int rc = esr_file_write_atomic(path, text, (size_t)len);
    free(half), free(zbuf), free(text);
    return rc;
}

int lightmix_page_write(const char *dir, const struct lightmix_page *p, const struct esr_model *m)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/index.html", dir);
    ESR_TRY(esr_file_write_atomic(path, esr_lightmix_page_html, esr_lightmix_page_html_size));
    cJSON *r = cJSON_CreateObject();
    cJSON_AddStringToObject(r, "run", p->run);
    cJSON_AddStringToObject(r, "method", p->method);
    cJSON_AddNumberToObject(r, "spp", p->spp);
    cJSON_AddNumberToObject(r, "orbit", p->orbit);
    cJSON_AddNumberToObject(r, "size", p->width);
    cJSON_AddStringToObject(r, "phase", p->phase ? p->phase : "");
    cJSON *lights = cJSON_AddArrayToObject(r, "lights");
    for (int k = 0; k < m->lights.n; k++) {
        const struct esr_light *lt = &m->lights.light[k];
        float hsv[3], chroma[3];
        esr_rgb_to_hsv(lt->radiance, hsv);
        for (int c = 0; c < 3; c++)
            chroma[c] = hsv[2] > 0.0f ? lt->radiance[c] / hsv[2] : 0.0f;
        cJSON *l = cJSON_CreateObject();
        cJSON_AddNumberToObject(l, "id", k);
        cJSON_AddItemToObject(l, "centroid", esr_json_float_array(lt->centroid, 3));
        cJSON_AddItemToObject(l, "rgb", esr_json_float_array(lt->radiance, 3));
        cJSON_AddItemToObject(l, "hsv", esr_json_float_array(hsv, 3));
        cJSON_AddItemToObject(l, "chroma", esr_json_float_array(chroma, 3));
        cJSON_AddItemToArray(lights, l);
    }
    cJSON *views = cJSON_AddArrayToObject(r, "views");
    for (int i = 0; i < p->n; i++) {
        char file[ESR_NAME_MAX + 8];
        snprintf(file, sizeof file, "%s.js", p->names[p->data_of[i]]);
        cJSON *v = cJSON_CreateObject();
        cJSON_AddStringToObject(v, "name", p->names[i]);
        cJSON_AddNumberToObject(v, "width", p->size[i][0]);
        cJSON_AddNumberToObject(v, "height", p->size[i][1]);
        cJSON_AddStringToObject(v, "file", file);
        cJSON_AddItemToArray(views, v);
    }
    char *json = cJSON_PrintUnformatted(r);
    cJSON_Delete(r);
    if (!json)
        return ESR_FAIL("lightmix: out of memory for lightmix.js");
    const size_t n = strlen(json) + 64;
    char *text = malloc(n);
    int rc = text ? ESR_OK : ESR_FAIL("lightmix: out of memory for lightmix.js");
    if (rc == ESR_OK) {
        const int len = snprintf(text, n, "window.LIGHTMIX = %s;\n", json);
        snprintf(path, sizeof path, "%s/lightmix.js", dir);
        rc = esr_file_write_atomic(path, text, (size_t)len);
    }
    free(text);
    cJSON_free(json);
    return rc;
}
