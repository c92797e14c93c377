/* esr metrics A B [--json FILE]: PSNR / SSIM / MSE between two images. */
#include <cJSON.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/colour.h"
#include "core/error.h"
#include "eval/metrics.h"
#include "io/file.h"
#include "io/image.h"
#include "io/json_file.h"

static int run_metrics(int argc, char **argv);

struct metrics_args {
    struct cli_texts images; /* A and B */
    const char *json;
};

#define AT(field) offsetof(struct metrics_args, field)
static const struct cli_option metrics_options[] = {
    {"A B", .kind = CLI_ARGS, .at = AT(images), .hi = 2,
     .bad = "expected exactly two images, got a third: '%s'"},
    {"--json", "FILE", "also write the JSON object to FILE (atomically)", CLI_TEXT, .at = AT(json)},
    {0},
};

const struct esr_command cmd_metrics = {
    .name = "metrics",
    .summary = "PSNR, SSIM and MSE between two images (PNG, EXR or JPEG)",
    .usage =
    "usage: esr metrics A B [--json FILE]\n"
    "\n"
    "Compares image A with image B and prints one JSON object to stdout:\n"
    "  {\"psnr\": dB, \"ssim\": s, \"mse\": m, \"width\": w, \"height\": h}\n"
    "Images with alpha are composited on white first (PNG: straight alpha; EXR: premultiplied),\n"
    "so dataset RGBA PNGs compare as the method sees them. PSNR uses peak 1.0 (values in [0,1];\n"
    "EXR values are compared as stored, linear); it is null for identical images (infinite).\n"
    "SSIM is the NeRF-literature variant (11x11 Gaussian, sigma 1.5, valid borders, per-channel\n"
    "mean); it is null for images under 11x11 pixels. An EXR (linear) is not compared with a\n"
    "PNG or JPEG (sRGB-encoded): compare like with like (esr render writes N.exr beside\n"
    "N_linear.png, the linear render through the sRGB curve).\n",
    .options = metrics_options,
    .run = run_metrics,
};

/* Reads path and returns it as RGB (or grey) without alpha, composited on white. */
static int load_opaque(const char *path, struct esr_image *out)
{
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    struct esr_image raw = {0};
    ESR_TRY(esr_image_read(path, &raw));
    if (raw.channels == 1 || raw.channels == 3) {
        *out = raw;
        return ESR_OK;
    }
    if (raw.channels == 2) {
        esr_image_free(&raw);
        return ESR_FAIL("'%s': grey+alpha images are not supported; convert to RGBA", path);
    }
    int premultiplied = esr_image_is_exr(path); /* OpenEXR stores premultiplied colour */
    int status = premultiplied ? esr_image_composite_premultiplied(&raw, white, out)
                               : esr_image_composite(&raw, white, out);
    esr_image_free(&raw);
    return status;
}

static int compute(const char *path_a, const char *path_b, cJSON *obj)
{
    if (esr_image_is_exr(path_a) != esr_image_is_exr(path_b))
        return ESR_FAIL("'%s' holds %s values and '%s' %s ones: the numbers would compare two "
                        "encodings, not two images (compare an EXR with an EXR, a PNG with a PNG)",
                        path_a, esr_image_is_exr(path_a) ? "linear" : "sRGB-encoded", path_b,
                        esr_image_is_exr(path_b) ? "linear" : "sRGB-encoded");
    struct esr_image a = {0}, b = {0};
    double mse = 0.0, ssim = NAN;
    int status = load_opaque(path_a, &a);
    if (status == ESR_OK)
        status = load_opaque(path_b, &b);
    if (status == ESR_OK && (a.width != b.width || a.height != b.height || a.channels != b.channels))
        status = ESR_FAIL("'%s' is %dx%d with %d channels but '%s' is %dx%d with %d channels", path_a, a.width,
                          a.height, a.channels, path_b, b.width, b.height, b.channels);
    if (status == ESR_OK)
        status = esr_metric_mse(&a, &b, &mse);
    if (status == ESR_OK && a.width >= 11 && a.height >= 11) /* the SSIM window's size */
        status = esr_metric_ssim(&a, &b, &ssim);
    if (status == ESR_OK) {
        /* identical images: PSNR +inf, written as null; SSIM of a small image: null */
        esr_json_add_number_or_null(obj, "psnr", esr_psnr_from_mse(mse));
        esr_json_add_number_or_null(obj, "ssim", ssim);
        cJSON_AddNumberToObject(obj, "mse", mse);
        cJSON_AddNumberToObject(obj, "width", a.width);
        cJSON_AddNumberToObject(obj, "height", a.height);
    }
    esr_image_free(&a);
    esr_image_free(&b);
    return status;
}

static int run_metrics(int argc, char **argv)
{
    struct metrics_args a;
    memset(&a, 0, sizeof a);
    const int parsed = cli_parse(&cmd_metrics, argc, argv, &a);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    if (a.images.n != 2)
        return cli_fail(&cmd_metrics, "expected two images A and B");
    const char *const *paths = a.images.v, *json_path = a.json;
    cJSON *obj = cJSON_CreateObject();
    if (!obj)
        return cli_fail(&cmd_metrics, "out of memory");
    if (compute(paths[0], paths[1], obj) != ESR_OK) {
        cJSON_Delete(obj);
        return cli_fail_lib(&cmd_metrics);
    }
    char *text = cJSON_PrintUnformatted(obj);
    cJSON_Delete(obj);
    if (!text)
        return cli_fail(&cmd_metrics, "out of memory");
    int status = json_path ? esr_file_write_atomic(json_path, text, strlen(text)) : ESR_OK;
    if (status == ESR_OK)
        printf("%s\n", text);
    free(text);
    return status == ESR_OK ? 0 : cli_fail_lib(&cmd_metrics);
}
