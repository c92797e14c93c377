/* Writes the seed corpora (corpus/<harness>/) and the JSON dictionary (json.dict) with esr's own
 * writers, so the seeds follow the formats as esr writes them:
 *   build/fuzz/fuzz_make_seeds fuzz
 * Every seed is small (libFuzzer's default input length follows the largest seed). esr writes no
 * COLMAP models, so those seeds are written here: text as COLMAP writes it, binary from the
 * parsed text in COLMAP's binary layout. The JPEG seeds come from fuzz/make_jpeg_seeds.sh. */
#include "colmap_fuzz.h" /* first: it asks for _GNU_SOURCE */

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

/* COLMAP text models as COLMAP writes them (its header comments, an empty keypoint line for an
 * image without keypoints), the three files joined by the harness's separator. */
static const struct {
    const char *name, *cameras, *images, *points;
} colmap_models[] = {
    {"two_cameras",
     "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
     "# Number of cameras: 2\n3 SIMPLE_RADIAL 64 48 60 32 24 -0.05\n9 OPENCV 64 48 61 59 31 25 -0.04 0.01 0.001 -0.001\n",
     "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
     "#   POINTS2D[] as (X, Y, POINT3D_ID)\n# Number of images: 3, mean observations per image: 1\n"
     "10 0.8 0 -0.3 0.2 0.5 0 4 3 off/p0.jpg\n10.5 20.25 1 1 2 -1\n"
     "11 0.8 0.1 -0.3 0.2 0.5 -0.25 4 3 on/p1.jpg\n\n"
     "12 0.8 0.2 -0.3 0.2 0.5 -0.5 4 9 on/p2.jpg\n30 40 2\n",
     "# 3D point list with one line of data per point:\n"
     "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
     "# Number of points: 2, mean track length: 1.5\n1 -0.5 -0.375 -0.25 16 32 48 0.5 10 0 12 0\n"
     "2 0.25 0.375 0.5 255 0 7 1.25 11 1\n"},
    {"every_model",
     "1 SIMPLE_PINHOLE 640 480 500 320 240\n2 PINHOLE 640 480 500 520 320 240\n"
     "3 SIMPLE_RADIAL 640 480 500 320 240 -0.12\n4 RADIAL 640 480 500 320 240 -0.12 0.03\n"
     "5 OPENCV 640 480 500 520 320 240 -0.12 0.03 0.001 -0.002\n",
     "1 1 0 0 0 0 0 4 1 off/a.png\n\n2 0.7071067811865476 0 0.7071067811865476 0 0 0 4 5 on/b c.jpg\n\n",
     ""},
    {"crlf",
     "# cameras\r\n1 PINHOLE 8 6 10 10 4 3\r\n",
     "1 1 0 0 0 0 0 1 1 off/x.jpg\r\n1 2 -1\r\n\r\n",
     "# 3D point list\r\n7 1e-3 -2.5E+2 0 1 2 3 0.1 1 0\r\n"},
};

/* Little-endian bytes into a seed buffer. */
struct seed_bytes {
    unsigned char data[4096];
    size_t n;
};

static void put_le(struct seed_bytes *b, uint64_t v, int n)
{
    if (b->n + (size_t)n > sizeof b->data)
        die("COLMAP seed too large");
    for (int i = 0; i < n; i++)
        b->data[b->n++] = (unsigned char)(v >> (8 * i));
}

static void put_doubles(struct seed_bytes *b, const double *v, int n)
{
    for (int i = 0; i < n; i++) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        put_le(b, bits, 8);
    }
}

static void put_text(struct seed_bytes *b, const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        put_le(b, (unsigned char)s[i], 1);
}

/* The parsed model in COLMAP's binary layout (colmap_binary.c's header), one keypoint per image
 * and a one-entry track per point. */
static void colmap_binary(const struct esr_colmap_model *m, struct seed_bytes *b)
{
    static const char sep[] = FUZZ_COLMAP_SEP;
    put_le(b, (uint64_t)m->n_cameras, 8);
    for (int i = 0; i < m->n_cameras; i++) {
        const struct esr_colmap_camera *c = &m->cameras[i];
        put_le(b, c->id, 4), put_le(b, (uint64_t)c->model, 4), put_le(b, (uint64_t)c->width, 8);
        put_le(b, (uint64_t)c->height, 8), put_doubles(b, c->params, esr_colmap_model_n_params(c->model));
    }
    put_text(b, sep, sizeof sep - 1);
    put_le(b, (uint64_t)m->n_images, 8);
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_colmap_image *im = &m->images[i];
        static const double keypoint[2] = {10.5, 20.25};
        put_le(b, im->id, 4), put_doubles(b, im->q, 4), put_doubles(b, im->t, 3), put_le(b, im->camera_id, 4);
        put_text(b, im->name, strlen(im->name) + 1);
        put_le(b, 1, 8), put_doubles(b, keypoint, 2), put_le(b, UINT64_MAX, 8); /* no 3D point */
    }
    put_text(b, sep, sizeof sep - 1);
    put_le(b, (uint64_t)m->n_points, 8);
    for (long i = 0; i < m->n_points; i++) {
        static const double error = 0.5;
        put_le(b, (uint64_t)i + 1, 8), put_doubles(b, m->points + 3 * i, 3), put_le(b, 0x302010, 3);
        put_doubles(b, &error, 1), put_le(b, 1, 8), put_le(b, 1, 4), put_le(b, 0, 4);
    }
}

static void seed_colmap(void)
{
    static const char *const names[ESR_COLMAP_FILES] = {"cameras.txt", "images.txt", "points3D.txt"};
    for (size_t i = 0; i < sizeof colmap_models / sizeof colmap_models[0]; i++) {
        char name[64], *text;
        size_t n;
        FILE *f = open_memstream(&text, &n);
        if (!f)
            die("memstream");
        fprintf(f, "%s%s%s%s%s", colmap_models[i].cameras, FUZZ_COLMAP_SEP, colmap_models[i].images, FUZZ_COLMAP_SEP,
                colmap_models[i].points);
        fclose(f);
        snprintf(name, sizeof name, "%s.txt", colmap_models[i].name);
        seed_text("colmap_text", name, text);
        struct esr_colmap_file files[ESR_COLMAP_FILES];
        struct esr_colmap_model m;
        fuzz_colmap_split((const uint8_t *)text, n, names, files);
        if (esr_colmap_model_parse_text(files, &m) != ESR_OK)
            die(name);
        struct seed_bytes b = {.n = 0};
        colmap_binary(&m, &b);
        esr_colmap_model_free(&m);
        free(text);
        snprintf(name, sizeof name, "%s.bin", colmap_models[i].name);
        FILE *out = fopen(seed_path("colmap_bin", name), "wb");
        if (!out || fwrite(b.data, 1, b.n, out) != b.n || fclose(out) != 0)
            die(name);
    }
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
        "preset", "fast", "paper", "data", "data_dir", "dataset", "loss", "psnr", "tight_min", "tight_max",
        "iter"};
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
    seed_colmap();
    write_dict();
    return 0;
}
