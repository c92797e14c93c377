/* Writes the seed corpora (corpus/<harness>/) and the JSON dictionary (json.dict) with esr's own
 * writers, so the seeds follow the formats as esr writes them:
 *   build/fuzz/fuzz_make_seeds fuzz
 * Every seed is small (libFuzzer's default input length follows the largest seed). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "io/image.h"
#include "io/ply.h"
#include "model/model.h"

static const char *root;

static void die(const char *what)
{
    fprintf(stderr, "fuzz_make_seeds: %s: %s\n", what, esr_error_message());
    exit(1);
}

/* "<root>/corpus/<harness>/<name>", the folders made on the way. */
static const char *seed_path(const char *harness, const char *name)
{
    static char path[2048];
    snprintf(path, sizeof path, "%s/corpus", root);
    mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/corpus/%s", root, harness);
    mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/corpus/%s/%s", root, harness, name);
    return path;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f || fputs(text, f) < 0 || fclose(f) != 0) {
        fprintf(stderr, "fuzz_make_seeds: cannot write %s\n", path);
        exit(1);
    }
}

static void seed_text(const char *harness, const char *name, const char *text)
{
    write_text(seed_path(harness, name), text);
}

/* A 5x3 image (not square, so a swapped width and height shows) of varied values. */
static void test_image(struct esr_image *img, int channels)
{
    if (esr_image_alloc(img, 5, 3, channels) != ESR_OK)
        die("image");
    for (size_t i = 0; i < esr_image_count(img); i++)
        img->data[i] = (float)(i % 11) / 10.0f;
}

static void seed_images(void)
{
    char name[64];
    for (int channels = 1; channels <= 4; channels++) {
        struct esr_image img;
        test_image(&img, channels);
        for (int bits = 8; bits <= 16; bits += 8) {
            snprintf(name, sizeof name, "c%d_%dbit.png", channels, bits);
            if (esr_png_write(seed_path("png", name), &img, bits) != ESR_OK)
                die(name);
        }
        esr_image_free(&img);
    }
    static const struct {
        int channels;
        enum esr_exr_pixel pixel;
        enum esr_exr_compression compression;
        const char *name;
    } exrs[] = {
        {4, ESR_EXR_HALF, ESR_EXR_ZIP, "rgba_half_zip.exr"},  {3, ESR_EXR_FLOAT, ESR_EXR_NONE, "rgb_float_none.exr"},
        {1, ESR_EXR_UINT, ESR_EXR_RLE, "y_uint_rle.exr"},     {2, ESR_EXR_HALF, ESR_EXR_ZIPS, "ya_half_zips.exr"},
        {4, ESR_EXR_HALF, ESR_EXR_PIZ, "rgba_half_piz.exr"},
    };
    for (size_t i = 0; i < sizeof exrs / sizeof exrs[0]; i++) {
        struct esr_image img;
        test_image(&img, exrs[i].channels);
        if (esr_exr_write_as(seed_path("exr", exrs[i].name), &img, exrs[i].pixel, exrs[i].compression) != ESR_OK)
            die(exrs[i].name);
        esr_image_free(&img);
    }
}

static void seed_ply(void)
{
    float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, normal[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
    struct esr_mesh m = {4, 2, pos, normal, NULL, tri};
    if (esr_ply_write(seed_path("ply", "binary.ply"), &m) != ESR_OK)
        die("binary.ply");
    seed_text("ply", "ascii_quad.ply",
              "ply\nformat ascii 1.0\ncomment a quad\nelement vertex 4\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\n"
              "end_header\n0 0 0 255\n1 0 0 0\n1 1 0 9\n0 1 0 1\n4 0 1 2 3\n");
    seed_text("ply", "ascii_list_on_vertex.ply",
              "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty double x\r\nproperty double y\r\n"
              "property double z\r\nproperty list uchar float extra\r\nelement face 1\r\n"
              "property uchar flags\r\nproperty list uint uint vertex_index\r\nend_header\r\n"
              "0 0 0 2 0.5 0.5\r\n1 0 0 0\r\n0 1 0 1 7\r\n3 3 0 1 2\r\n");
}

/* The smallest model the options allow: an alphamask stage on an 8^3 lattice. */
static void tiny_model(struct esr_model *m)
{
    struct esr_train_config cfg;
    esr_config_defaults(&cfg, ESR_PRESET_FAST);
    cfg.alphamask.res = 8;
    cfg.alphamask.feat_channels = 1;
    static const float smin[3] = {-1, -1, -1}, smax[3] = {1, 1, 1};
    if (esr_model_init(m, &cfg, ESR_STAGE_ALPHAMASK, NULL, smin, smax) != ESR_OK)
        die("tiny model");
}

/* A mask cache and one light on a 2^3 lattice, so their readers have seeds too. */
static void add_mask_and_light(struct esr_model *m)
{
    struct esr_grid lat;
    static const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    if (esr_grid_init(&lat, 1, 2, 2, 2, bmin, bmax) != ESR_OK || esr_mask_alloc(&m->mask, &lat) != ESR_OK)
        die("mask");
    m->has_mask = 1;
    memset(m->mask.occ, 1, 8);
    m->lights.grid = lat;
    m->lights.label = calloc(8, 1);
    if (!m->lights.label)
        die("labels");
    m->lights.label[3] = 1;
    m->lights.n = 1;
    struct esr_light *l = &m->lights.light[0];
    l->area = 0.5f;
    l->points = 1;
    for (int k = 0; k < 3; k++)
        l->field_rgb[k] = l->scale[k] = l->radiance[k] = 1.0f;
}

static void seed_checkpoints(void)
{
    struct esr_model m;
    tiny_model(&m);
    if (esr_model_save(&m, seed_path("checkpoint", "alphamask.bin")) != ESR_OK)
        die("alphamask.bin");
    add_mask_and_light(&m);
    if (esr_model_save(&m, seed_path("checkpoint", "mask_light.bin")) != ESR_OK)
        die("mask_light.bin");
    esr_model_free(&m);
}

static void seed_json(void)
{
    seed_text("config", "flat.json", "{\"fine.iters\": 3000, \"seed\": 7, \"smooth_sigma\": 0.5}\n");
    seed_text("config", "nested.json", "{\"preset\": \"paper\", \"fine\": {\"iters\": 20, \"res\": 64}, \"pdra.k0\": 0.1}\n");
    seed_text("config", "empty.json", "{}\n");
    seed_text("dataset", "esr_train.json",
              "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"train/r_000\", \"transform_matrix\": "
              "[[1,0,0,0.5],[0,1,0,-0.25],[0,0,1,4],[0,0,0,1]], \"lights\": [{\"mode\": \"off\", \"intensity\": 0, "
              "\"color\": [0,0,1], \"mask_path\": \"\"}]}, {\"file_path\": \"train/r_100_on\", \"transform_matrix\": "
              "[[0,-1,0,0],[1,0,0,0],[0,0,1,4],[0,0,0,1]], \"lights\": [{\"mode\": \"on\", \"intensity\": 1, "
              "\"color\": [0,0,1], \"mask_path\": \"\"}]}]}\n");
    seed_text("dataset", "esr_test_nvc.json",
              "{\"camera_angle_x\": 0.5, \"frames\": [{\"file_path\": \"test_nvc/c000_c1\", \"transform_matrix\": "
              "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]], \"lights\": [{\"mode\": \"c_change\", "
              "\"mask_path\": \"masks/nvc_c000_c1_l0\", \"color\": [0.333333, 1.0, 1.0], \"intensity\": 1.0}, "
              "{\"mode\": \"ic_change\", \"mask_path\": \"masks/nvc_c000_c1_l1\", \"color\": [0.8, 1, 1], "
              "\"intensity\": 2.0}]}]}\n");
    seed_text("dataset", "scene.json",
              "{\"bounding_box\": {\"min\": [-1.5,-1.5,-1.5], \"max\": [1.5,1.5,1.5]}, \"lights\": [{\"index\": 0, "
              "\"name\": \"shade\", \"emitted_radiance_on\": [8, 6.4, 4.4]}, {\"name\": \"bulb\"}]}\n");
}

/* Every key esr's JSON readers look up: the fixed ones and every option and component name. */
static void write_dict(void)
{
    static const char *const keys[] = {
        "camera_angle_x", "frames", "file_path", "transform_matrix", "lights", "mode", "intensity", "color",
        "mask_path", "off", "on", "i_change", "c_change", "ic_change", "bounding_box", "min", "max",
        "emitted_radiance_on", "name", "stage", "step", "done", "scene_min", "scene_max", "config", "params",
        "components", "offset", "count", "mask", "dims", "bmin", "bmax", "table", "centroid", "area", "points",
        "field_rgb", "scale", "radiance", "power", "calib_points", "alphamask", "coarse", "fine", "lts", "pdra",
        "preset", "fast", "paper"};
    char path[2048];
    snprintf(path, sizeof path, "%s/json.dict", root);
    FILE *f = fopen(path, "w");
    if (!f)
        die("json.dict");
    fprintf(f, "# JSON keys esr reads (written by fuzz/make_seeds.c)\n");
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        fprintf(f, "\"\\\"%s\\\"\"\n", keys[i]);
    struct esr_train_config cfg;
    esr_config_defaults(&cfg, ESR_PRESET_FAST);
    cJSON *opts = esr_config_to_json(&cfg);
    for (const cJSON *it = opts ? opts->child : NULL; it; it = it->next)
        fprintf(f, "\"\\\"%s\\\"\"\n", it->string);
    cJSON_Delete(opts);
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        fprintf(f, "\"\\\"%s\\\"\"\n", esr_component_info((enum esr_component)c)->name);
    fclose(f);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: fuzz_make_seeds FUZZ_DIR\n");
        return 1;
    }
    root = argv[1];
    seed_images();
    seed_ply();
    seed_checkpoints();
    seed_json();
    write_dict();
    return 0;
}
