/* The option table and everything derived from it (see config.h). */
#include "model/config.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "io/json_file.h"

enum opt_type { OPT_INT, OPT_FLOAT };

struct opt {
    const char *name;
    enum opt_type type;
    size_t offset;                 /* into struct esr_train_config */
    double lo, hi;                 /* inclusive bounds */
    double def[ESR_PRESET_COUNT];  /* fast, paper */
    const char *help;
};

#define OFF(field) offsetof(struct esr_train_config, field)
/* The three stages share option names below their prefix. */
#define STAGE_OPTS(st, res_f, res_p, it_f, it_p, fc_f, fc_p, w_f, w_p, d_f, d_p, lg, lf, lm, fin,    \
                   s_f, s_p, sd_f, sd_p, tvs, tvg, tvf)                                                   \
    {#st ".res", OPT_INT, OFF(st.res), 8, 512, {res_f, res_p}, "grid lattice points per axis"},     \
    {#st ".iters", OPT_INT, OFF(st.iters), 0, 1000000, {it_f, it_p}, "iterations"},                \
    {#st ".feat_channels", OPT_INT, OFF(st.feat_channels), 1, 64, {fc_f, fc_p},                      \
     "feature grid channels"},                                                                      \
    {#st ".mlp_width", OPT_INT, OFF(st.mlp_width), 8, 256, {w_f, w_p}, "MLP hidden width"},         \
    {#st ".mlp_depth", OPT_INT, OFF(st.mlp_depth), 1, 8, {d_f, d_p}, "MLP hidden layers"},          \
    {#st ".lr_grid", OPT_FLOAT, OFF(st.lr_grid), 0, 10, {lg, lg}, "density/SDF grid learning rate"}, \
    {#st ".lr_feat", OPT_FLOAT, OFF(st.lr_feat), 0, 10, {lf, lf}, "feature grid learning rate"},    \
    {#st ".lr_mlp", OPT_FLOAT, OFF(st.lr_mlp), 0, 1, {lm, lm}, "MLP learning rate"},                \
    {#st ".lr_final", OPT_FLOAT, OFF(st.lr_final), 0, 1, {fin, fin},                                \
     "learning-rate factor reached at the last iteration"},                                         \
    {#st ".s0", OPT_FLOAT, OFF(st.s0), 0.1, 10000, {s_f, s_p}, "NeuS inv-s at step 0"},               \
    {#st ".s_div", OPT_FLOAT, OFF(st.s_div), 0.01, 1e6, {sd_f, sd_p},                               \
     "inv-s grows by step / s_div"},                                                                \
    {#st ".tv_sdf", OPT_FLOAT, OFF(st.tv_sdf), 0, 100, {tvs, tvs}, "grid total-variation weight"},  \
    {#st ".tv_sdf_grad", OPT_FLOAT, OFF(st.tv_sdf_grad), 0, 100, {tvg, tvg},                        \
     "smoothed-gradient total-variation weight on the SDF (Voxurf; 0 = off)"},                      \
    {#st ".tv_feat", OPT_FLOAT, OFF(st.tv_feat), 0, 100, {tvf, tvf},                                \
     "feature-grid total-variation weight"},                                                        \
    {#st ".step_vox", OPT_FLOAT, OFF(st.step_vox), 0.05, 4, {0.5, 0.5},                             \
     "ray-marching step in voxels"}

static const struct opt opts[] = {
    {"seed", OPT_INT, OFF(seed), 0, 2147483647, {1, 1}, "random seed (rays, jitter, init)"},
    {"batch_rays", OPT_INT, OFF(batch_rays), 16, 65536, {4096, 8192}, "rays per iteration"},
    {"save_every", OPT_INT, OFF(save_every), 1, 1000000, {500, 2000},
     "checkpoint every N iterations within a stage"},
    {"log_every", OPT_INT, OFF(log_every), 1, 1000000, {50, 100}, "log line every N iterations"},
    {"threads", OPT_INT, OFF(threads), 0, 1024, {0, 0}, "OpenMP threads (0 = default)"},
    {"alpha_thres", OPT_FLOAT, OFF(alpha_thres), 1e-7, 0.5, {1e-3, 1e-3},
     "mask cache: density alpha threshold"},
    {"smooth_ksize", OPT_INT, OFF(smooth_ksize), 0, 9, {5, 5},
     "SDF Gaussian smoothing kernel (0 = off, odd)"},
    {"smooth_sigma", OPT_FLOAT, OFF(smooth_sigma), 0.1, 5, {0.8, 0.8}, "SDF smoothing sigma"},
    {"geo_scales", OPT_INT, OFF(geo_scales), 1, 4, {2, 4},
     "fine: geometry-feature scales (first K of 0.5,1,1.5,2 voxels)"},
    {"pe_pos", OPT_INT, OFF(pe_pos), 0, 10, {5, 5}, "fine: PE frequencies of the position"},
    {"pe_dir", OPT_INT, OFF(pe_dir), 0, 6, {1, 1}, "fine: PE frequencies of the view direction"},
    {"tone_width", OPT_INT, OFF(tone_width), 4, 256, {32, 192}, "fine: tone-mapper width"},
    {"tone_pe", OPT_INT, OFF(tone_pe), 0, 8, {3, 5}, "fine: tone-mapper PE frequencies"},
    {"lambda_tau", OPT_FLOAT, OFF(lambda_tau), 0, 100, {1.0, 0.1},
     "fine: weight of the gamma(linear) loss"},
    {"sdf_init_alpha", OPT_FLOAT, OFF(sdf_init_alpha), 1e-6, 1, {0.05, 0.05},
     "coarse: initial SDF = signed distance to the alphamask voxels with alpha above this"},
    {"fine_mask_band", OPT_FLOAT, OFF(fine_mask_band), 0, 1000, {4, 0},
     "fine: mask cache narrowed to |coarse SDF| <= this many coarse voxels (0 = off)"},
    {"mlp_engine", OPT_INT, OFF(mlp_engine), 0, 2, {1, 1},
     "MLP training kernels: 0 esr's fused kernel (bitwise the same for any thread count), "
     "1 oneDNN (fastest in `esr bench`), 2 OpenBLAS"},
    {"tv_every", OPT_INT, OFF(tv_every), 1, 1000, {4, 1},
     "total-variation regularisers every N iterations (weight scaled by N)"},
    STAGE_OPTS(alphamask, 80, 100, 500, 10000, 6, 6, 8, 8, 1, 1, 0.1, 0.1, 1e-3, 0.1, 1, 1, 1, 1, 0,
               0, 0),
    STAGE_OPTS(coarse, 80, 96, 1500, 10000, 12, 12, 64, 128, 2, 3, 1e-2, 0.1, 1e-3, 0.1, 5, 5, 10, 50,
               1e-3, 0, 0),
    STAGE_OPTS(fine, 128, 160, 2000, 20000, 6, 6, 64, 192, 3, 4, 2e-3, 0.1, 1e-3, 0.1, 100, 20, 20,
               100, 1e-3, 0, 0),
};
#define N_OPTS (sizeof opts / sizeof opts[0])

static const char *preset_names[ESR_PRESET_COUNT] = {"fast", "paper"};

const char *esr_preset_name(enum esr_preset p)
{
    return p >= 0 && p < ESR_PRESET_COUNT ? preset_names[p] : NULL;
}

int esr_preset_from_name(const char *name, enum esr_preset *out)
{
    for (int i = 0; i < ESR_PRESET_COUNT; i++)
        if (!strcmp(name, preset_names[i])) {
            *out = (enum esr_preset)i;
            return ESR_OK;
        }
    return ESR_FAIL("unknown preset '%s' (valid: fast, paper)", name);
}

static void opt_store(struct esr_train_config *c, const struct opt *o, double v)
{
    char *p = (char *)c + o->offset;
    if (o->type == OPT_INT) {
        int i = (int)v;
        memcpy(p, &i, sizeof i);
    } else {
        float f = (float)v;
        memcpy(p, &f, sizeof f);
    }
}

static double opt_load(const struct esr_train_config *c, const struct opt *o)
{
    const char *p = (const char *)c + o->offset;
    if (o->type == OPT_INT) {
        int i;
        memcpy(&i, p, sizeof i);
        return i;
    }
    float f;
    memcpy(&f, p, sizeof f);
    return f;
}

void esr_config_defaults(struct esr_train_config *c, enum esr_preset preset)
{
    memset(c, 0, sizeof(*c));
    c->preset = preset;
    for (size_t i = 0; i < N_OPTS; i++)
        opt_store(c, &opts[i], opts[i].def[preset]);
}

static const struct opt *opt_find(const char *name)
{
    for (size_t i = 0; i < N_OPTS; i++)
        if (!strcmp(opts[i].name, name))
            return &opts[i];
    return NULL;
}

/* Checks v against o's type and bounds; `where` prefixes the message. */
static int opt_check(const struct opt *o, double v, const char *where)
{
    if (!isfinite(v))
        return ESR_FAIL("%s: option '%s' must be a finite number", where, o->name);
    if (o->type == OPT_INT && v != floor(v))
        return ESR_FAIL("%s: option '%s' must be an integer (got %g)", where, o->name, v);
    if (v < o->lo || v > o->hi)
        return ESR_FAIL("%s: option '%s' = %g is out of range [%g, %g]", where, o->name, v, o->lo,
                        o->hi);
    if (!strcmp(o->name, "smooth_ksize") && v != 0 && ((int)v % 2) == 0)
        return ESR_FAIL("%s: option 'smooth_ksize' must be 0 or odd (got %g)", where, v);
    return ESR_OK;
}

static int opt_apply(struct esr_train_config *c, const char *key, double v, const char *where)
{
    const struct opt *o = opt_find(key);
    if (!o)
        return ESR_FAIL("%s: unknown option '%s' (see `esr train --help`)", where, key);
    ESR_TRY(opt_check(o, v, where));
    opt_store(c, o, v);
    return ESR_OK;
}

int esr_config_set(struct esr_train_config *c, const char *assignment)
{
    const char *eq = strchr(assignment, '=');
    char key[128];
    if (!eq || eq == assignment || (size_t)(eq - assignment) >= sizeof key)
        return ESR_FAIL("--set '%s': expected key=value", assignment);
    memcpy(key, assignment, (size_t)(eq - assignment));
    key[eq - assignment] = '\0';
    char *end;
    errno = 0;
    double v = strtod(eq + 1, &end);
    if (end == eq + 1 || *end != '\0' || errno)
        return ESR_FAIL("--set '%s': value '%s' is not a number", assignment, eq + 1);
    return opt_apply(c, key, v, "--set");
}

int esr_config_validate(const struct esr_train_config *c)
{
    for (size_t i = 0; i < N_OPTS; i++)
        ESR_TRY(opt_check(&opts[i], opt_load(c, &opts[i]), "config"));
    return ESR_OK;
}

/* Applies the members of obj, prefixing nested object keys with "prefix." (one level). */
static int json_apply(struct esr_train_config *c, const cJSON *obj, const char *prefix,
                      const char *path)
{
    char where[1200];
    for (const cJSON *it = obj->child; it; it = it->next) {
        char key[160];
        snprintf(key, sizeof key, "%s%s%s", prefix, prefix[0] ? "." : "", it->string);
        snprintf(where, sizeof where, "config file %s", path);
        if (!prefix[0] && !strcmp(it->string, "preset"))
            continue; /* applied first by the caller */
        if (cJSON_IsObject(it) && !prefix[0]) {
            ESR_TRY(json_apply(c, it, it->string, path));
            continue;
        }
        if (!cJSON_IsNumber(it)) {
            if (!opt_find(key))
                return ESR_FAIL("%s: unknown option '%s'", where, key);
            return ESR_FAIL("%s: option '%s' must be a number", where, key);
        }
        ESR_TRY(opt_apply(c, key, it->valuedouble, where));
    }
    return ESR_OK;
}

int esr_config_load_json(struct esr_train_config *c, const char *path)
{
    unsigned char *text;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &text, &size));
    cJSON *root = cJSON_Parse((const char *)text);
    free(text);
    if (!root || !cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return ESR_FAIL("config file %s: not a JSON object", path);
    }
    int rc = ESR_OK;
    const cJSON *preset = cJSON_GetObjectItemCaseSensitive(root, "preset");
    if (preset) {
        enum esr_preset p = ESR_PRESET_FAST;
        if (!cJSON_IsString(preset))
            rc = ESR_FAIL("config file %s: 'preset' must be a string (fast or paper)", path);
        else if (esr_preset_from_name(preset->valuestring, &p) == ESR_OK)
            esr_config_defaults(c, p);
        else
            rc = ESR_ERR;
    }
    if (rc == ESR_OK)
        rc = json_apply(c, root, "", path);
    cJSON_Delete(root);
    return rc;
}

int esr_config_write_json(const struct esr_train_config *c, const char *path)
{
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return ESR_FAIL("config %s: out of memory", path);
    cJSON_AddStringToObject(root, "preset", esr_preset_name((enum esr_preset)c->preset));
    /* Options are floats: print the shortest text that reads back to the same float (0.001, not
     * 0.0010000000474974513). */
    for (size_t i = 0; i < N_OPTS; i++) {
        char num[32];
        double v = opt_load(c, &opts[i]);
        snprintf(num, sizeof num, "%.9g", v);
        if (v == floor(v) && fabs(v) < 1e9) /* integers as integers, never 5e+02 */
            snprintf(num, sizeof num, "%.0f", v);
        else
            for (int digits = 1; digits <= 9; digits++) {
                char shorter[32];
                snprintf(shorter, sizeof shorter, "%.*g", digits, v);
                if ((float)strtod(shorter, NULL) == (float)v) {
                    memcpy(num, shorter, sizeof num);
                    break;
                }
            }
        cJSON_AddRawToObject(root, opts[i].name, num);
    }
    return esr_json_write_atomic(path, root);
}

void esr_config_print_help(FILE *out)
{
    fprintf(out, "  %-24s %-5s %-18s %-9s %-9s %s\n", "option", "type", "range", "fast", "paper",
            "meaning");
    for (size_t i = 0; i < N_OPTS; i++) {
        const struct opt *o = &opts[i];
        char range[64];
        snprintf(range, sizeof range, "[%g, %g]", o->lo, o->hi);
        fprintf(out, "  %-24s %-5s %-18s %-9g %-9g %s\n", o->name,
                o->type == OPT_INT ? "int" : "float", range, o->def[0], o->def[1], o->help);
    }
}
