/* Lights as objects (train/lights/lights.h, model/lights.h): the emitting surface split into lights, each
 * light's area and centroid, point lookups, and the lights' round trip through a checkpoint. The
 * emission field is made constant (zero weights, last bias b: E = softplus(b) everywhere), so
 * which surfaces emit is decided by the geometry alone and the answers are known: a sphere of
 * radius r has area 4 pi r^2 and its centre as centroid. The cameras are parallel rays from
 * around the box (26 directions; one test looks from above only); only surface they can reach
 * counts. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/grid.h"
#include "model/material_fields.h"
#include "model/model.h"
#include "test_model.h"
#include "test_support.h"
#include "train/lights/direct.h"
#include "train/lights/lights.h"

#define RES 48
/* camera rays: 26 directions (cube faces, edges, corners), a GRID x GRID bundle of parallel
 * rays each */
#define GRID 40
#define N_RAYS (26 * GRID * GRID)

static float ray_orig[N_RAYS * 3], ray_dir[N_RAYS * 3];

/* A bundle of GRID x GRID parallel rays along unit d, 2.4 wide (the box, 2 wide, seen from any
 * direction), starting 3 units out; written from ray r on, returns the next ray. */
static size_t add_bundle(const float d[3], float *orig, float *dir, size_t r)
{
    /* two unit vectors across d */
    float u[3] = {-d[1], d[0], 0.0f};
    if (fabsf(d[2]) > 0.9f)
        u[0] = 1.0f, u[1] = 0.0f, u[2] = 0.0f;
    float ul = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int a = 0; a < 3; a++)
        u[a] /= ul;
    const float v[3] = {d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
    for (int i = 0; i < GRID; i++)
        for (int j = 0; j < GRID; j++, r++) {
            const float a = 2.4f * ((float)i + 0.5f) / GRID - 1.2f;
            const float b = 2.4f * ((float)j + 0.5f) / GRID - 1.2f;
            for (int c = 0; c < 3; c++) {
                orig[r * 3 + c] = -3.0f * d[c] + a * u[c] + b * v[c];
                dir[r * 3 + c] = d[c];
            }
        }
    return r;
}

/* Bundles towards the origin from 26 directions (cube faces, edges, corners). */
static void make_rays(void)
{
    size_t r = 0;
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                if (!dx && !dy && !dz)
                    continue;
                const float len = sqrtf((float)(dx * dx + dy * dy + dz * dz));
                const float d[3] = {-dx / len, -dy / len, -dz / len};
                r = add_bundle(d, ray_orig, ray_dir, r);
            }
}

/* Finds m's lights from n lights-on rays whose photos are mid grey (every ray sees clearly). */
static int find_lights_from(struct esr_model *m, const float *orig, const float *dir, size_t n)
{
    static float grey[N_RAYS * 3];
    for (size_t i = 0; i < n * 3; i++)
        grey[i] = 0.5f;
    const struct esr_ray_set rs = {.n = n, .orig3 = (float *)orig, .dir3 = (float *)dir, .rgb3 = grey};
    return esr_lights_find(m, &rs);
}

static int find_lights(struct esr_model *m)
{
    return find_lights_from(m, ray_orig, ray_dir, N_RAYS);
}

/* A pdra-stage model on [-1, 1]^3 whose SDF is the union of spheres centred at c3[s] of radius
 * r and whose emission is the constant softplus(bias). */
static void setup_at(struct esr_model *m, const float (*c3)[3], int n_spheres, float r, float bias)
{
    struct esr_train_config cfg;
    test_small_config(&cfg, 0.5f);
    cfg.pdra.res = RES;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_model_init(m, &cfg, ESR_STAGE_PDRA, NULL, bmin, bmax), ESR_OK);
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    float *f = esr_model_values(m, ESR_COMP_SDF);
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3], d = INFINITY;
                esr_grid_voxel_pos(g, x, y, z, p);
                for (int s = 0; s < n_spheres; s++) {
                    const float dx = p[0] - c3[s][0], dy = p[1] - c3[s][1], dz = p[2] - c3[s][2];
                    d = fminf(d, sqrtf(dx * dx + dy * dy + dz * dz) - r);
                }
                f[((size_t)z * g->ny + y) * g->nx + x] = d;
            }
    const struct esr_mlp *e = esr_model_mlp(m, ESR_COMP_EMIT_MLP);
    memset(m->params.w + e->offset, 0, e->count * sizeof(float));
    for (int c = 0; c < 3; c++)
        m->params.w[e->b_off[e->n_layers - 1] + (size_t)c] = bias;
}

/* setup_at with the spheres on the x axis at cx[s]. */
static void setup(struct esr_model *m, const float *cx, int n_spheres, float r, float bias)
{
    float c3[4][3];
    assert_true(n_spheres <= 4);
    for (int s = 0; s < n_spheres; s++)
        c3[s][0] = cx[s], c3[s][1] = 0.0f, c3[s][2] = 0.0f;
    setup_at(m, (const float(*)[3])c3, n_spheres, r, bias);
}

/* More emitting regions than esr keeps as lights (ESR_MAX_LIGHTS = 16): 18 spheres on a 3 x 3 x 2
 * lattice; the 16 largest are the lights, and the two left out are counted (the trainer and
 * `esr lights` say so) instead of vanishing. */
static void test_lights_beyond_the_limit_are_counted(void **state)
{
    (void)state;
    float c3[18][3];
    for (int s = 0; s < 18; s++) {
        c3[s][0] = -0.55f + 0.55f * (float)(s % 3);
        c3[s][1] = -0.55f + 0.55f * (float)(s / 3 % 3);
        c3[s][2] = s < 9 ? -0.3f : 0.3f;
    }
    struct esr_model m;
    setup_at(&m, (const float(*)[3])c3, 18, 0.13f, 3.0f);
    assert_int_equal(find_lights(&m), ESR_OK);
    assert_int_equal(m.lights.n, ESR_MAX_LIGHTS);
    assert_int_equal(m.lights.n_left_out, 18 - ESR_MAX_LIGHTS);
    esr_model_free(&m);
    /* within the limit nothing is left out */
    setup_at(&m, (const float(*)[3])c3, 9, 0.13f, 3.0f);
    assert_int_equal(find_lights(&m), ESR_OK);
    assert_int_equal(m.lights.n, 9);
    assert_int_equal(m.lights.n_left_out, 0);
    esr_model_free(&m);
}

/* One emitting sphere of radius 0.5 at x = 0.1, its light found. */
static void setup_one_light(struct esr_model *m)
{
    const float cx[1] = {0.1f};
    setup(m, cx, 1, 0.5f, 3.0f);
    assert_int_equal(find_lights(m), ESR_OK);
    assert_int_equal(m->lights.n, 1);
}

static void test_one_emitting_sphere_is_one_light(void **state)
{
    (void)state;
    struct esr_model m;
    setup_one_light(&m);
    const struct esr_light *l = &m.lights.light[0];
    const double area = 4.0 * M_PI * 0.25;
    print_message("sphere r 0.5: area %.4f (true %.4f), centroid %.3f %.3f %.3f, E %.3f\n",
                  (double)l->area, area, (double)l->centroid[0], (double)l->centroid[1],
                  (double)l->centroid[2], (double)l->field_rgb[0]);
    assert_true(fabs(l->area - area) < 0.05 * area); /* measured 1.1% */
    assert_true(fabsf(l->centroid[0] - 0.1f) < 0.02f && fabsf(l->centroid[1]) < 0.02f &&
                fabsf(l->centroid[2]) < 0.02f);
    const float e = log1pf(expf(3.0f));
    for (int c = 0; c < 3; c++) {
        assert_true(fabsf(l->field_rgb[c] - e) < 1e-3f * e);
        assert_true(l->scale[c] == 1.0f && l->radiance[c] == l->field_rgb[c]);
    }
    /* a point on the surface is on light 0; the centre and far space are on none */
    const float on[3] = {0.6f, 0.0f, 0.0f}, inside[3] = {0.1f, 0.0f, 0.0f}, away[3] = {-0.9f, 0.9f, 0.9f};
    assert_int_equal(esr_lights_id_at(&m.lights, on), 0);
    assert_int_equal(esr_lights_id_at(&m.lights, inside), -1);
    assert_int_equal(esr_lights_id_at(&m.lights, away), -1);
    esr_model_free(&m);
}

static void test_two_spheres_are_two_lights(void **state)
{
    (void)state;
    struct esr_model m;
    const float cx[2] = {-0.5f, 0.45f};
    setup(&m, cx, 2, 0.3f, 3.0f);
    assert_int_equal(find_lights(&m), ESR_OK);
    assert_int_equal(m.lights.n, 2);
    const double area = 4.0 * M_PI * 0.09;
    int left = m.lights.light[0].centroid[0] < 0.0f ? 0 : 1;
    for (int i = 0; i < 2; i++) {
        const struct esr_light *l = &m.lights.light[i];
        print_message("light %d: area %.4f (true %.4f), centroid x %.3f\n", i, (double)l->area,
                      area, (double)l->centroid[0]);
        assert_true(fabs(l->area - area) < 0.05 * area); /* measured 3.1%, 1.1% */
        assert_true(fabsf(l->centroid[0] - cx[i == left ? 0 : 1]) < 0.02f);
    }
    /* ids follow size, largest first */
    assert_true(m.lights.light[0].points >= m.lights.light[1].points);
    const float p_left[3] = {-0.5f, 0.3f, 0.0f}, p_right[3] = {0.45f, 0.0f, -0.3f};
    assert_int_equal(esr_lights_id_at(&m.lights, p_left), left);
    assert_int_equal(esr_lights_id_at(&m.lights, p_right), 1 - left);
    /* dropping light 0 (a reflection, say): its surface is no light, light 1 becomes light 0
     * with its table entry */
    const struct esr_light second = m.lights.light[1];
    assert_int_equal(esr_lights_drop(&m.lights, 2), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "the run has 2 lights"));
    esr_error_clear();
    assert_int_equal(esr_lights_drop(&m.lights, 0), ESR_OK);
    assert_int_equal(m.lights.n, 1);
    assert_memory_equal(&m.lights.light[0], &second, sizeof second);
    assert_int_equal(esr_lights_id_at(&m.lights, left == 0 ? p_left : p_right), -1);
    assert_int_equal(esr_lights_id_at(&m.lights, left == 0 ? p_right : p_left), 0);
    assert_int_equal(esr_lights_drop(&m.lights, 0), ESR_OK); /* the last: none left */
    assert_int_equal(m.lights.n, 0);
    assert_null(m.lights.label);
    assert_int_equal(esr_lights_id_at(&m.lights, p_left), -1);
    esr_model_free(&m);
}

static void test_dark_field_has_no_lights(void **state)
{
    (void)state;
    struct esr_model m;
    const float cx[1] = {0.0f};
    setup(&m, cx, 1, 0.5f, -6.0f); /* E = softplus(-6) ~ 0.0025, below k */
    assert_int_equal(find_lights(&m), ESR_OK);
    assert_int_equal(m.lights.n, 0);
    assert_null(m.lights.label);
    const float on[3] = {0.5f, 0.0f, 0.0f};
    assert_int_equal(esr_lights_id_at(&m.lights, on), -1);
    esr_model_free(&m);
}

static void test_lights_survive_a_checkpoint(void **state)
{
    (void)state;
    struct esr_model m, back;
    const float cx[2] = {-0.5f, 0.45f};
    setup(&m, cx, 2, 0.3f, 3.0f);
    assert_int_equal(find_lights(&m), ESR_OK);
    m.lights.light[1].scale[2] = 7.5f; /* as a calibration would set it */
    char path[4200];
    snprintf(path, sizeof path, "%s/lights.bin", test_tmpdir);
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    assert_int_equal(esr_model_load(&back, path), ESR_OK);
    assert_int_equal(back.lights.n, 2);
    assert_memory_equal(back.lights.light, m.lights.light, sizeof m.lights.light);
    assert_memory_equal(back.lights.label, m.lights.label, esr_grid_voxels(&m.lights.grid));
    /* the fingerprint renders record: the same after the round trip, another for other lights */
    const uint64_t fp = esr_lights_fingerprint(&m.lights);
    assert_true(esr_lights_fingerprint(&back.lights) == fp);
    m.lights.light[1].scale[2] = 7.25f;
    assert_true(esr_lights_fingerprint(&m.lights) != fp);
    m.lights.light[1].scale[2] = 7.5f;
    m.lights.label[esr_grid_voxels(&m.lights.grid) / 2] ^= 1;
    assert_true(esr_lights_fingerprint(&m.lights) != fp);
    /* a colour balance survives the round trip and changes the fingerprint; none is not stored */
    assert_false(esr_lights_balanced(&back.lights));
    esr_model_free(&back);
    m.lights.balance[0] = 1.25f, m.lights.balance[1] = 0.9f, m.lights.balance[2] = 0.8f;
    assert_true(esr_lights_fingerprint(&m.lights) != fp);
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    assert_int_equal(esr_model_load(&back, path), ESR_OK);
    assert_memory_equal(back.lights.balance, m.lights.balance, sizeof m.lights.balance);
    memset(m.lights.balance, 0, sizeof m.lights.balance);
    /* a scaled light's emission is reported scaled */
    float pos[3] = {0.45f, 0.0f, -0.3f}, e[3] = {1.0f, 1.0f, 1.0f};
    const int id = esr_lights_id_at(&back.lights, pos);
    esr_lights_scale_emission(&back.lights, pos, 1, e);
    assert_true(e[2] == back.lights.light[id].scale[2] && e[0] == back.lights.light[id].scale[0]);
    /* a light's unseen part keeps its id through id_at and a checkpoint; a flag on no light is
     * refused when the checkpoint is read */
    const size_t nl = esr_grid_voxels(&m.lights.grid);
    size_t at = 0;
    while (at < nl && !m.lights.label[at])
        at++;
    assert_true(at < nl);
    const int light = ESR_LIGHT_LABEL_ID(m.lights.label[at]);
    for (size_t i = 0; i < nl; i++)
        if (ESR_LIGHT_LABEL_ID(m.lights.label[i]) == light)
            m.lights.label[i] |= ESR_LIGHT_UNSEEN;
    assert_int_equal(esr_lights_id_at(&m.lights, pos), id);
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    esr_model_free(&back);
    assert_int_equal(esr_model_load(&back, path), ESR_OK);
    assert_memory_equal(back.lights.label, m.lights.label, nl);
    assert_int_equal(esr_lights_id_at(&back.lights, pos), id);
    esr_model_free(&back);
    const size_t empty = (size_t)(strchr((const char *)m.lights.label, 0) - (const char *)m.lights.label);
    assert_true(empty < nl); /* a lattice point of no light */
    m.lights.label[empty] = ESR_LIGHT_UNSEEN;
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    assert_int_not_equal(esr_model_load(&back, path), ESR_OK);
    assert_non_null(strstr(esr_error_message(), "light label"));
    esr_error_clear();
    m.lights.label[empty] = 0;
    /* nor is an undecided rim saved, or read: the calibration settles every one */
    m.lights.label[at] |= ESR_LIGHT_UNDECIDED;
    assert_int_not_equal(esr_model_save(&m, path), ESR_OK);
    assert_non_null(strstr(esr_error_message(), "undecided"));
    esr_error_clear();
    m.lights.label[at] &= (uint8_t)~ESR_LIGHT_UNDECIDED;
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    { /* the same flag written into the file's labels, its CRC-32 made right again */
        FILE *f = fopen(path, "rb");
        assert_non_null(f);
        fseek(f, 0, SEEK_END);
        const long size = ftell(f);
        fseek(f, 0, SEEK_SET);
        unsigned char *bytes = malloc((size_t)size);
        assert_non_null(bytes);
        assert_int_equal(fread(bytes, 1, (size_t)size, f), (size_t)size);
        fclose(f);
        bytes[(size_t)size - 4 - nl + at] |= ESR_LIGHT_UNDECIDED; /* labels, then the CRC */
        const uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), bytes, (uInt)(size - 4));
        memcpy(bytes + size - 4, &crc, 4);
        f = fopen(path, "wb");
        assert_non_null(f);
        assert_int_equal(fwrite(bytes, 1, (size_t)size, f), (size_t)size);
        fclose(f);
        free(bytes);
    }
    assert_int_not_equal(esr_model_load(&back, path), ESR_OK);
    assert_non_null(strstr(esr_error_message(), "light label"));
    esr_error_clear();
    /* labels on a lattice other than the SDF's (fewer points, or another box) are refused: they
     * are read at the SDF's indices */
    const struct esr_grid keep = m.lights.grid;
    for (int change = 0; change < 2; change++) {
        m.lights.grid = keep;
        if (change == 0)
            m.lights.grid.nz -= 1;
        else
            m.lights.grid.bmax[1] += 0.25f;
        assert_int_equal(esr_model_save(&m, path), ESR_OK);
        assert_int_not_equal(esr_model_load(&back, path), ESR_OK);
        if (!strstr(esr_error_message(), "the light labels' lattice"))
            fail_msg("change %d: %s", change, esr_error_message());
        esr_error_clear();
    }
    m.lights.grid = keep;
    esr_model_free(&m);
}

/* A hollow emitting sphere: the inner wall (a cavity no camera sees into) emits as much as the
 * outer one, but only the outer surface is a light. */
static void test_unseen_cavity_is_no_light(void **state)
{
    (void)state;
    struct esr_model m;
    const float cx[1] = {0.0f};
    setup(&m, cx, 1, 0.6f, 3.0f);
    const struct esr_grid *g = esr_model_grid(&m, ESR_COMP_SDF);
    float *f = esr_model_values(&m, ESR_COMP_SDF);
    for (int z = 0; z < g->nz; z++) /* carve a cavity of radius 0.3 */
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                float *v = &f[((size_t)z * g->ny + y) * g->nx + x];
                *v = fmaxf(*v, 0.3f - sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]));
            }
    assert_int_equal(find_lights(&m), ESR_OK);
    assert_int_equal(m.lights.n, 1);
    const double outer = 4.0 * M_PI * 0.36, inner = 4.0 * M_PI * 0.09;
    print_message("hollow sphere: area %.4f (outer %.4f, with the cavity %.4f)\n",
                  (double)m.lights.light[0].area, outer, outer + inner);
    assert_true(fabs(m.lights.light[0].area - outer) < 0.05 * outer);
    const float wall[3] = {0.3f, 0.0f, 0.0f}, shell[3] = {0.0f, 0.6f, 0.0f};
    assert_int_equal(esr_lights_id_at(&m.lights, wall), -1);
    assert_int_equal(esr_lights_id_at(&m.lights, shell), 0);
    /* with no camera rays there is no free space: nothing is seen, nothing is a light */
    assert_int_equal(find_lights_from(&m, ray_orig, ray_dir, 0), ESR_OK);
    assert_int_equal(m.lights.n, 0);
    esr_model_free(&m);
}

/* E = softplus(f - 6), f = 9 on the emission feature grid's lattice points above z_from and 0
 * below: the emission MLP passes feature 0 through one unit of each hidden layer (ReLU) to every
 * channel. High (3.05) above, dark (0.0025) below, one feature voxel between. */
static void emission_above(struct esr_model *m, float z_from)
{
    const struct esr_mlp *e = esr_model_mlp(m, ESR_COMP_EMIT_MLP);
    float *w = m->params.w;
    memset(w + e->offset, 0, e->count * sizeof(float));
    for (int l = 0; l + 1 < e->n_layers; l++)
        w[e->w_off[l]] = 1.0f; /* input 0 -> unit 0 */
    const int last = e->n_layers - 1;
    for (int c = 0; c < 3; c++) {
        w[e->w_off[last] + (size_t)c] = 1.0f;
        w[e->b_off[last] + (size_t)c] = -6.0f;
    }
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_EMO_FEAT);
    float *f = esr_model_values(m, ESR_COMP_EMO_FEAT);
    memset(f, 0, esr_grid_voxels(g) * (size_t)g->channels * sizeof(float));
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++) {
                float p[3];
                esr_grid_voxel_pos(g, x, y, z, p);
                if (p[2] > z_from)
                    f[(((size_t)z * g->ny + y) * g->nx + x) * (size_t)g->channels] = 9.0f;
            }
}

/* Lattice points of the lights' labels that carry ESR_LIGHT_UNSEEN; their lowest and highest z. */
static long unseen_points(const struct esr_lights *L, float *zmin, float *zmax)
{
    const struct esr_grid *g = &L->grid;
    long n = 0;
    *zmin = INFINITY, *zmax = -INFINITY;
    for (int z = 0; z < g->nz; z++)
        for (int y = 0; y < g->ny; y++)
            for (int x = 0; x < g->nx; x++)
                if (L->label[((size_t)z * g->ny + y) * g->nx + x] & ESR_LIGHT_UNSEEN) {
                    float p[3];
                    esr_grid_voxel_pos(g, x, y, z, p);
                    *zmin = fminf(*zmin, p[2]), *zmax = fmaxf(*zmax, p[2]);
                    n++;
                }
    return n;
}

/* A light the cameras see only from above (as a lampshade's underside): a sphere of radius 0.5
 * emitting down to z = -0.1, the cameras looking straight down. They see the upper hemisphere
 * (and one lattice point past the equator); the light joins the outer surface points no camera
 * sees that touch it: a band below the equator, beside which the rays that pass the sphere carve
 * free space. Further down the normals point into the sphere's shadow, where no ray goes: not
 * outer, not joined. The joined points carry the unseen flag, count in the light's area and emit
 * the light's mean field. With only a cap above z = 0.2 emitting, the seen dark band between it and
 * the equator keeps the unseen band off the light: nothing joins. */
static void test_light_grows_over_its_unseen_part(void **state)
{
    (void)state;
    static float orig[GRID * GRID * 3], dir[GRID * GRID * 3];
    const float down[3] = {0.0f, 0.0f, -1.0f};
    add_bundle(down, orig, dir, 0);
    struct esr_model m;
    const float cx[1] = {0.0f};
    setup(&m, cx, 1, 0.5f, 0.0f);
    emission_above(&m, -0.1f);
    assert_int_equal(find_lights_from(&m, orig, dir, GRID * GRID), ESR_OK);
    assert_int_equal(m.lights.n, 1);
    const struct esr_light *l = &m.lights.light[0];
    float zmin, zmax;
    const long grown = unseen_points(&m.lights, &zmin, &zmax);
    const double cap = 2.0 * M_PI * 0.5 * 0.6, hemisphere = 2.0 * M_PI * 0.25; /* z > -0.1, z > 0 */
    print_message("light seen from above: %ld points, area %.4f (z > 0: %.4f, z > -0.1: %.4f), E %.3f; "
                  "grown %ld points, z %.3f .. %.3f\n", l->points, (double)l->area, hemisphere, cap,
                  (double)l->field_rgb[0], grown, (double)zmin, (double)zmax);
    /* the light's area counts both parts: the emitting cap (E crosses k within a feature voxel of
     * z = -0.1, so at least the hemisphere), and the band grown below it, down to where the
     * normals point into the shadow (z = -0.23: the 1.5-voxel step out along the normal leaves
     * the rays' column beside the sphere) */
    const double band_area = 2.0 * M_PI * 0.5 * 0.23;
    assert_true(l->area > 0.95 * hemisphere && l->area < 1.1 * (hemisphere + band_area));
    assert_true(grown > 0);
    assert_true(zmax < 0.0f && zmin > -0.4f); /* below the equator, above the shadow */
    long unseen[ESR_MAX_LIGHTS];
    esr_lights_unseen_points(&m.lights, unseen);
    assert_int_equal(unseen[0], grown);
    const float band[3] = {0.0f, 0.48f, -0.18f}, pole[3] = {0.0f, 0.0f, -0.5f};
    assert_int_equal(esr_lights_id_at(&m.lights, band), 0);
    assert_int_equal(esr_lights_id_at(&m.lights, pole), -1);
    /* the samples: the seen points emit their field, the grown ones the light's mean field */
    struct esr_light_samples smp;
    assert_int_equal(esr_light_samples_get(&m, 0, &smp), ESR_OK);
    assert_int_equal((long)smp.n, l->points);
    long mean_emitters = 0;
    for (size_t i = 0; i < smp.n; i++) {
        if (smp.pos3[i * 3 + 2] < -0.25f) { /* where the field is dark */
            assert_float_equal(smp.emit3[i * 3 + 1], l->field_rgb[1], 0.0f);
            mean_emitters++;
        }
        assert_true(smp.emit3[i * 3] > m.cfg.emitter_k); /* no sample of the light is dark */
    }
    assert_true(mean_emitters > 0);
    esr_light_samples_free(&smp);
    /* what a camera sees there is what the samples cast: the mean field at the light's scale
     * (it showed the dark field's E: a dimmer light than the one lighting the scene) */
    m.lights.light[0].scale[0] = 2.0f, m.lights.light[0].scale[1] = 3.0f, m.lights.light[0].scale[2] = 4.0f;
    float e_band[3] = {0.01f, 0.02f, 0.03f}, e_seen[3] = {0.5f, 0.6f, 0.7f};
    const float seen[3] = {0.0f, 0.0f, 0.5f};
    esr_lights_scale_emission(&m.lights, band, 1, e_band);
    esr_lights_scale_emission(&m.lights, seen, 1, e_seen);
    for (int c = 0; c < 3; c++) {
        assert_float_equal(e_band[c], l->field_rgb[c] * (float)(c + 2), 1e-6f);
        assert_float_equal(e_seen[c], (0.5f + 0.1f * (float)c) * (float)(c + 2), 1e-6f);
    }
    /* a seen dark band between the light and the unseen band: nothing joins */
    emission_above(&m, 0.2f);
    assert_int_equal(find_lights_from(&m, orig, dir, GRID * GRID), ESR_OK);
    assert_int_equal(m.lights.n, 1);
    assert_int_equal(unseen_points(&m.lights, &zmin, &zmax), 0);
    esr_lights_unseen_points(&m.lights, unseen);
    assert_int_equal(unseen[0], 0);
    print_message("cap above z = 0.2: area %.4f, nothing grown\n", (double)m.lights.light[0].area);
    esr_model_free(&m);
}

/* The light of test_light_grows_over_its_unseen_part, seen clearly from above (grey photos) and
 * from the side by lights-on cameras whose photos are clipped white (what an emitter, or the
 * floor beside a strong one, shows): the band below its emitting part that only clipped pixels
 * see may emit or not, so it is the light's undecided rim, one lattice point deep. Settled with
 * the light, it joins as unseen surface and the area grows; settled without, it leaves. */
static void test_clipped_band_is_an_undecided_rim(void **state)
{
    (void)state;
    enum { SIDES = 4, RAYS = (1 + SIDES) * GRID * GRID };
    static float orig[RAYS * 3], dir[RAYS * 3], rgb[RAYS * 3];
    const float views[1 + SIDES][3] = {{0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
    size_t r = 0;
    for (int v = 0; v <= SIDES; v++) {
        const size_t r0 = r;
        r = add_bundle(views[v], orig, dir, r);
        for (size_t i = r0 * 3; i < r * 3; i++)
            rgb[i] = v == 0 ? 0.5f : 1.0f; /* from the side: clipped */
    }
    const struct esr_ray_set rs = {.n = r, .orig3 = orig, .dir3 = dir, .rgb3 = rgb};
    struct esr_model m;
    const float cx[1] = {0.0f};
    setup(&m, cx, 1, 0.5f, 0.0f);
    emission_above(&m, -0.1f);
    const float h = esr_grid_voxel_size(esr_model_grid(&m, ESR_COMP_SDF), 0);
    for (int emits = 0; emits <= 1; emits++) {
        assert_int_equal(esr_lights_find(&m, &rs), ESR_OK);
        assert_int_equal(m.lights.n, 1);
        const struct esr_grid *g = &m.lights.grid;
        long rim = 0;
        float zmin = INFINITY, zmax = -INFINITY;
        for (size_t i = 0; i < esr_grid_voxels(g); i++)
            if (m.lights.label[i] & ESR_LIGHT_UNDECIDED) {
                assert_int_equal(ESR_LIGHT_LABEL_ID(m.lights.label[i]), 1);
                assert_true(m.lights.label[i] & ESR_LIGHT_UNSEEN);
                float p[3];
                esr_grid_voxel_pos(g, (int)(i % (size_t)g->nx), (int)(i / (size_t)g->nx % (size_t)g->ny),
                                   (int)(i / ((size_t)g->nx * (size_t)g->ny)), p);
                zmin = fminf(zmin, p[2]), zmax = fmaxf(zmax, p[2]);
                rim++;
            }
        const float area = m.lights.light[0].area;
        const int emits_arr[ESR_MAX_LIGHTS] = {emits};
        assert_int_equal(esr_lights_settle(&m, emits_arr), ESR_OK);
        long left = 0;
        for (size_t i = 0; i < esr_grid_voxels(g); i++)
            left += (m.lights.label[i] & ESR_LIGHT_UNDECIDED) != 0;
        print_message("clipped band: rim of %ld points at z %.3f .. %.3f; area %.4f with it, %.4f "
                      "settled %s\n", rim, (double)zmin, (double)zmax, (double)area,
                      (double)m.lights.light[0].area, emits ? "emitting" : "dark");
        assert_int_equal(left, 0);
        assert_true(rim > 0);
        /* one lattice point below the emitting part's edge (E crosses k within a feature voxel
         * of z = -0.1) */
        assert_true(zmax < 0.0f && zmin > -0.1f - 3.0f * h);
        const float band[3] = {0.0f, 0.49f, zmin + 0.25f * h};
        if (emits) {
            assert_float_equal(m.lights.light[0].area, area, 1e-6f * area);
            assert_int_equal(esr_lights_id_at(&m.lights, band), 0);
        } else {
            assert_true(m.lights.light[0].area < area);
        }
    }
    esr_model_free(&m);
}

/* The calibration fits the lights of at least 5% of the lights' area; a smaller one takes the
 * fitted lights' area-weighted mean scale, per channel. */
static void test_small_light_shares_the_fitted_scale(void **state)
{
    (void)state;
    struct esr_lights L;
    memset(&L, 0, sizeof L);
    L.n = 3;
    const float area[3] = {0.729f, 0.141f, 0.011f}; /* lamp's lampshade, bulb, mirror speck */
    for (int a = 0; a < 3; a++)
        L.light[a].area = area[a];
    int fit[ESR_MAX_LIGHTS];
    assert_int_equal(esr_lights_fitted(&L, fit), 2);
    assert_int_equal(fit[0], 0);
    assert_int_equal(fit[1], 1);
    assert_true(esr_light_strength_fitted(&L, 0) && esr_light_strength_fitted(&L, 1));
    assert_false(esr_light_strength_fitted(&L, 2));
    assert_false(esr_light_strength_fitted(&L, 3) || esr_light_strength_fitted(&L, -1)); /* no such light */
    L.light[0].scale[1] = 8.0f, L.light[1].scale[1] = 2.0f, L.light[2].scale[1] = 300.0f;
    esr_lights_share_scale(&L, 1);
    assert_float_equal(L.light[2].scale[1], (8.0f * 0.729f + 2.0f * 0.141f) / 0.870f, 1e-5f);
    assert_float_equal(L.light[0].scale[1], 8.0f, 0.0f);
    assert_float_equal(L.light[2].scale[0], 0.0f, 0.0f); /* channel 0 untouched */
    L.light[2].area = 0.05f * 0.92f; /* 5% of the total exactly: fitted */
    assert_int_equal(esr_lights_fitted(&L, fit), 3);
    assert_true(esr_light_strength_fitted(&L, 2));
    /* a row's columns: the left-out light's light joins each fitted light's column by area
     * share, so that a x s over the fitted lights is what the row sees once light 2 borrows */
    L.light[2].area = 0.011f;
    assert_int_equal(esr_lights_fitted(&L, fit), 2);
    const double a[3] = {0.5, 0.25, 0.125};
    double cols[2];
    esr_lights_fit_columns(&L, fit, 2, a, cols);
    assert_float_equal(cols[0], 0.5 + 0.729 / 0.870 * 0.125, 1e-6);
    assert_float_equal(cols[1], 0.25 + 0.141 / 0.870 * 0.125, 1e-6);
    L.light[0].scale[1] = 8.0f, L.light[1].scale[1] = 2.0f;
    esr_lights_share_scale(&L, 1);
    assert_float_equal(cols[0] * 8.0 + cols[1] * 2.0,
                       a[0] * 8.0 + a[1] * 2.0 + a[2] * L.light[2].scale[1], 1e-5);
    /* a calibration that fitted no light on any point is said to be one */
    assert_true(esr_lights_uncalibrated(&L));
    L.light[1].calib_points = 12.0f;
    assert_false(esr_lights_uncalibrated(&L));
    L.n = 0;
    assert_false(esr_lights_uncalibrated(&L)); /* no lights: nothing to calibrate */
}

/* The balance from silhouette and calibrated scales (esr_lights_balance_solve): each voting
 * light's calibrated colour over its silhouette's, less its mean over channels, averaged in logs
 * weighted by pixels. Two lights whose calibrated scales share one colour error b (geometric
 * mean 1) and whose silhouettes have the true colours at any magnitude give b back; a light with
 * too few pixels or a non-positive channel does not vote; none voting gives 1 1 1. */
static void test_balance_solve(void **state)
{
    (void)state;
    const float b_true[3] = {1.2f, 1.0f, 1.0f / 1.2f};
    const float colour[3][3] = {{8.0f, 6.4f, 4.4f}, {2.4f, 6.0f, 12.0f}, {1.0f, 1.0f, 1.0f}};
    const float magnitude[3] = {1.7f, 0.3f, 1.0f}, sil_size[3] = {0.12f, 0.2f, 1.0f};
    float scale[3][3], sil[3][3];
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++) {
            scale[k][c] = magnitude[k] * colour[k][c] * b_true[c];
            sil[k][c] = sil_size[k] * colour[k][c];
        }
    sil[2][1] = 3.0f; /* a light whose silhouette disagrees, with too few pixels to vote */
    long rows[3] = {640, 251, 20};
    float b[3];
    assert_int_equal(esr_lights_balance_solve(3, (const float(*)[3])sil, (const float(*)[3])scale,
                                              rows, b), 2);
    for (int c = 0; c < 3; c++)
        assert_float_equal(b[c], b_true[c], 1e-5f);
    rows[2] = 640; /* now it votes: b moves */
    assert_int_equal(esr_lights_balance_solve(3, (const float(*)[3])sil, (const float(*)[3])scale,
                                              rows, b), 3);
    assert_true(fabsf(b[1] - b_true[1]) > 0.1f);
    sil[2][1] = 0.0f; /* a dark channel: no colour to compare */
    assert_int_equal(esr_lights_balance_solve(3, (const float(*)[3])sil, (const float(*)[3])scale,
                                              rows, b), 2);
    /* two lights that disagree: the pixel-weighted mean of their errors in logs */
    const float b2[3] = {0.8f, 1.0f, 1.25f};
    for (int c = 0; c < 3; c++)
        scale[1][c] = magnitude[1] * colour[1][c] * b2[c];
    const long uneven[3] = {300, 100, 0};
    assert_int_equal(esr_lights_balance_solve(3, (const float(*)[3])sil, (const float(*)[3])scale,
                                              uneven, b), 2);
    for (int c = 0; c < 3; c++)
        assert_float_equal(b[c], expf(0.75f * logf(b_true[c]) + 0.25f * logf(b2[c])), 1e-5f);
    const long none[3] = {0, 10, 49};
    assert_int_equal(esr_lights_balance_solve(3, (const float(*)[3])sil, (const float(*)[3])scale,
                                              none, b), 0);
    assert_true(b[0] == 1.0f && b[1] == 1.0f && b[2] == 1.0f);
}

/* esr_lights_balance end to end on one emitting sphere seen by the 26 bundles (all lights-on
 * rays): the "photos" are the model's own lights-on renders with the light at a true scale s*,
 * and the calibrated scale is s* times a colour error b. The silhouette pixels (unclipped: s* is dim enough) give s*'s
 * colour back, so the balance found is b over its geometric mean and the scales end up s* times
 * one number. The base colour comes out times the balance, the environment over it, and the
 * light's direct effect, base colour x scale, stays as calibrated. */
static void test_balance_finds_the_silhouette_colour(void **state)
{
    (void)state;
    struct esr_model m;
    setup_one_light(&m);
    struct esr_light *l = &m.lights.light[0];
    /* dim radiance fields (softplus(-3) = 0.049 everywhere), so the photos are unclipped */
    const enum esr_component radiance[2] = {ESR_COMP_OFF_MLP, ESR_COMP_EMO_MLP};
    for (int k = 0; k < 2; k++) {
        const struct esr_mlp *r = esr_model_mlp(&m, radiance[k]);
        memset(m.params.w + r->offset, 0, r->count * sizeof(float));
        for (int c = 0; c < 3; c++)
            m.params.w[r->b_off[r->n_layers - 1] + (size_t)c] = -3.0f;
    }
    const float s_true[3] = {0.2f, 0.12f, 0.05f}, b[3] = {1.3f, 0.9f, 0.8f};
    for (int c = 0; c < 3; c++)
        l->scale[c] = s_true[c];
    static float lin[N_RAYS * 3], photo[N_RAYS * 3];
    const struct esr_render_out out = {.linear = lin, .lights_emitted_only = 1};
    assert_int_equal(esr_model_render_rays(&m, ray_orig, ray_dir, N_RAYS, 1, &out), ESR_OK);
    for (size_t i = 0; i < (size_t)N_RAYS * 3; i++)
        photo[i] = esr_srgb_from_linear(fminf(lin[i], 1.0f));
    for (int c = 0; c < 3; c++)
        l->scale[c] = s_true[c] * b[c];
    /* the base colour at a few points before */
    const float pts[3 * 3] = {0.6f, 0.0f, 0.0f, 0.1f, 0.5f, 0.0f, -0.2f, 0.3f, 0.2f};
    struct esr_material_fields mf;
    assert_int_equal(esr_material_fields_init(&mf, &m, 3, 0), ESR_OK);
    assert_int_equal(esr_material_fields_fwd(&mf, &m, esr_model_values(&m, ESR_COMP_SDF), pts, 3), ESR_OK);
    float before[3 * ESR_BRDF_CHANNELS];
    memcpy(before, mf.brdf5, sizeof before);
    const float scale_before[3] = {l->scale[0], l->scale[1], l->scale[2]};
    struct esr_lights_balance_info info;
    const struct esr_ray_set rs = {.n = N_RAYS, .orig3 = ray_orig, .dir3 = ray_dir, .rgb3 = photo};
    assert_int_equal(esr_lights_balance(&m, &rs, &info), ESR_OK);
    print_message("balance %.4f %.4f %.4f from %ld silhouette pixels; silhouette scale %.4f %.4f "
                  "%.4f\n", (double)info.applied[0], (double)info.applied[1],
                  (double)info.applied[2], info.rows[0], (double)info.silhouette[0][0],
                  (double)info.silhouette[0][1], (double)info.silhouette[0][2]);
    assert_int_equal(info.used, 1);
    assert_true(info.rows[0] >= 50);
    const float gm = cbrtf(b[0] * b[1] * b[2]);
    for (int c = 0; c < 3; c++) {
        assert_float_equal(info.applied[c], b[c] / gm, 2e-3f * b[c]);
        assert_float_equal(m.lights.balance[c], info.applied[c], 0.0f);
        assert_float_equal(l->scale[c] / s_true[c], gm, 2e-3f * gm);
        assert_float_equal(l->radiance[c], l->scale[c] * l->field_rgb[c], 1e-6f * l->radiance[c]);
    }
    assert_int_equal(esr_material_fields_fwd(&mf, &m, esr_model_values(&m, ESR_COMP_SDF), pts, 3), ESR_OK);
    for (int p = 0; p < 3; p++) {
        for (int c = 0; c < 3; c++) { /* base colour x scale: the light it casts, unchanged */
            const float *row = mf.brdf5 + p * ESR_BRDF_CHANNELS, *row0 = before + p * ESR_BRDF_CHANNELS;
            assert_float_equal(row[c], row0[c] * m.lights.balance[c], 1e-6f);
            assert_float_equal(row[c] * l->scale[c], row0[c] * scale_before[c], 1e-5f * row0[c] * scale_before[c]);
        }
        assert_float_equal(mf.brdf5[p * ESR_BRDF_CHANNELS + 3], before[p * ESR_BRDF_CHANNELS + 3], 0.0f);
    }
    float env[3] = {0.6f, 0.6f, 0.6f};
    esr_lights_balance_env(&m.lights, env, 1);
    for (int c = 0; c < 3; c++)
        assert_float_equal(env[c] * m.lights.balance[c], 0.6f, 1e-6f);
    /* the backward passes through the balance: the gradient of a balanced base colour is b times
     * the field's, as the unbalanced model's gradient at b times the same output gradient */
    esr_material_fields_free(&mf);
    assert_int_equal(esr_material_fields_init(&mf, &m, 3, ESR_MATERIAL_TRAIN), ESR_OK);
    float d_brdf[3 * ESR_BRDF_CHANNELS], d_scaled[3 * ESR_BRDF_CHANNELS];
    for (int i = 0; i < 3 * ESR_BRDF_CHANNELS; i++) {
        d_brdf[i] = 0.1f * (float)(i % 7) - 0.3f;
        d_scaled[i] = d_brdf[i] * (i % ESR_BRDF_CHANNELS < 3 ? m.lights.balance[i % ESR_BRDF_CHANNELS] : 1.0f);
    }
    const size_t ns = esr_grid_count(esr_model_grid(&m, ESR_COMP_SDF));
    float *grads[2], *g_sdf[2];
    const float keep[3] = {m.lights.balance[0], m.lights.balance[1], m.lights.balance[2]};
    for (int pass = 0; pass < 2; pass++) { /* 0: balanced, d_brdf; 1: none, d_scaled */
        grads[pass] = calloc(m.params.count, sizeof(float));
        g_sdf[pass] = calloc(ns, sizeof(float));
        if (pass == 1)
            memset(m.lights.balance, 0, sizeof m.lights.balance);
        assert_int_equal(esr_material_fields_fwd(&mf, &m, esr_model_values(&m, ESR_COMP_SDF), pts, 3), ESR_OK);
        assert_int_equal(esr_material_fields_bwd(&mf, &m, g_sdf[pass], grads[pass], NULL,
                                                 pass ? d_scaled : d_brdf), ESR_OK);
    }
    memcpy(m.lights.balance, keep, sizeof keep);
    double norm = 0.0;
    for (size_t i = 0; i < m.params.count; i++) {
        assert_float_equal(grads[0][i], grads[1][i], 1e-6f * (1.0f + fabsf(grads[1][i])));
        norm += fabs(grads[0][i]);
    }
    assert_true(norm > 0.0);
    for (int pass = 0; pass < 2; pass++)
        free(grads[pass]), free(g_sdf[pass]);
    esr_material_fields_free(&mf);
    /* the photos of a model already balanced: a second pass changes nothing, and the balance
     * it keeps is the first's (a pass multiplies the balance in place, it does not replace it) */
    assert_int_equal(esr_lights_balance(&m, &rs, &info), ESR_OK);
    for (int c = 0; c < 3; c++) {
        assert_float_equal(info.applied[c], 1.0f, 2e-3f);
        assert_float_equal(m.lights.balance[c], b[c] / gm, 4e-3f * b[c]);
    }
    esr_model_free(&m);
}

/* The direct-light kernel (train/lights/direct.h) against the formula it estimates, with nothing in
 * the way: one light sample y of area A and emission e, facing x, gives e R(wo, wi) |n_y . wi| A /
 * d^2 with wi and d taken from the lit point x itself, not from where its shadow ray starts (one
 * voxel up the normal): measured from there, a light 3 voxels above x came out 2.25x too bright. */
static void test_direct_light_is_measured_from_the_point(void **state)
{
    (void)state;
    struct esr_grid g;
    const float bmin[3] = {-1, -1, -1}, bmax[3] = {1, 1, 1};
    assert_int_equal(esr_grid_init(&g, 1, RES, RES, RES, bmin, bmax), ESR_OK);
    static float sdf[RES * RES * RES];
    for (size_t i = 0; i < esr_grid_voxels(&g); i++)
        sdf[i] = 1.0f; /* empty: every shadow ray gets through */
    struct esr_light_shadows sh;
    memset(&sh, 0, sizeof sh);
    assert_int_equal(esr_first_hit_shadow_setup(&sh.grid, &sh.params, &g, sdf), ESR_OK);
    sh.voxel = esr_grid_voxel_size(&g, 0);
    const float h = sh.voxel;
    const struct esr_material mat = {{0.8f, 0.6f, 0.4f}, 0.5f, 0.2f};
    const struct esr_vec3 x = {0.1f, -0.2f, -0.5f}, n = {0, 0, 1};
    const struct esr_vec3 wo = esr_v3_normalize((struct esr_vec3){0.3f, 0.2f, 1.0f});
    /* the sample: above x (and off to one side), facing down-ish */
    const float up[4] = {3, 6, 12, 24}, side[2] = {0, 4};
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 2; j++) {
            const struct esr_vec3 y = {x.x + side[j] * h, x.y, x.z + up[k] * h};
            const struct esr_vec3 ny = esr_v3_normalize((struct esr_vec3){-0.2f, 0.1f, -1.0f});
            float pos3[3] = {y.x, y.y, y.z}, nrm3[3] = {ny.x, ny.y, ny.z};
            float emit3[3] = {2.0f, 3.0f, 5.0f}, area = 0.7f * h * h;
            const struct esr_light_samples ls = {1, pos3, nrm3, emit3, &area, area, 5.0f};
            float got[1][3] = {{0}};
            struct esr_rng rng = esr_rng_init(7, 0);
            const struct esr_direct_point_query q = {&sh, &ls, NULL, 1, &mat, x, n, &wo, 1, 1.0f};
            assert_int_equal((int)esr_light_direct_point(&q, &rng, got, NULL, NULL), 1);
            const struct esr_vec3 v = esr_v3_sub(y, x);
            const float d = esr_v3_length(v);
            const struct esr_vec3 wi = esr_v3_scale(v, 1.0f / d);
            float R[3];
            esr_brdf_eval(&mat, n, wo, wi, R);
            for (int c = 0; c < 3; c++) {
                const float want = emit3[c] * R[c] * fabsf(esr_v3_dot(ny, wi)) * area / (d * d);
                if (fabsf(got[0][c] - want) > 1e-4f * want)
                    fail_msg("light %g voxels up, %g aside, channel %d: %g, want %g", (double)up[k],
                             (double)side[j], c, (double)got[0][c], (double)want);
            }
        }
    esr_first_hit_grid_free(&sh.grid);
}

int main(void)
{
    make_rays();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_one_emitting_sphere_is_one_light),
        cmocka_unit_test(test_two_spheres_are_two_lights),
        cmocka_unit_test(test_lights_beyond_the_limit_are_counted),
        cmocka_unit_test(test_dark_field_has_no_lights),
        cmocka_unit_test(test_lights_survive_a_checkpoint),
        cmocka_unit_test(test_unseen_cavity_is_no_light),
        cmocka_unit_test(test_light_grows_over_its_unseen_part),
        cmocka_unit_test(test_clipped_band_is_an_undecided_rim),
        cmocka_unit_test(test_small_light_shares_the_fitted_scale),
        cmocka_unit_test(test_direct_light_is_measured_from_the_point),
        cmocka_unit_test(test_balance_solve),
        cmocka_unit_test(test_balance_finds_the_silhouette_colour),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
