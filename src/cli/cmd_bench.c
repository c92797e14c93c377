/* esr bench: throughput of the kernels, the path tracer, the ray path and training, as JSON. */
#define _GNU_SOURCE
#include <cJSON.h>
#include <ftw.h>
#include <omp.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "cli/commands.h"
#include "core/isa.h"
#include "core/error.h"
#include "core/simd.h"
#include "edit/editor.h"
#include "eval/bench_ceiling.h"
#include "eval/bench_lts.h"
#include "eval/bench_train.h"
#include "eval/run_dir.h"
#include "io/dataset.h"
#include "io/file.h"
#include "io/json_file.h"
#include "nn/bench.h"
#include "model/bench_ray_path.h"
#include "synth/synth.h"
#include "nn/tile_gemm.h"

static int run_bench(int argc, char **argv);

struct bench_opts {
    const char *out, *data, *run;
    int quick, no_train;
    int iters; /* training iterations per stage; -1 = by --quick */
};

#define AT(field) offsetof(struct bench_opts, field)
static const struct cli_option bench_options[] = {
    {"--out", "FILE", "JSON output (default: bench.json)", CLI_TEXT, .at = AT(out)},
    {"--quick", NULL, "fewer repetitions, 40 training iterations per stage (a rough figure in well "
     "under a minute; its fine stage starts from a barely trained coarse model, so it marches far "
     "more samples per ray than a real run)", CLI_FLAG, .at = AT(quick)},
    {"--iters", "N", "training iterations per stage instead of the preset's", CLI_INT,
     .at = AT(iters), .lo = 2, .hi = 1000000,
     .bad = "--iters: expected an integer in 2..1000000, got '%s'"},
    {"--data", "DIR", "dataset for the training benchmark (and for --run's, instead of the one RUN "
     "records)", CLI_TEXT, .at = AT(data)},
    {"--no-train", NULL, "skip the training benchmark", CLI_FLAG, .at = AT(no_train)},
    {"--run", "RUN", "also compare the LTS estimators on RUN's pdra (else lts) checkpoint and time "
     "the direct and the ratio relight of its first test_nv view (and as light groups) and a "
     "fine-tune", CLI_TEXT, .at = AT(run)},
    {0},
};

const struct esr_command cmd_bench = {
    .name = "bench",
    .summary = "measure kernel, path-tracer, ray-path and training throughput (JSON + table)",
    .usage =
    "usage: esr bench [options]\n"
    "\n"
    "Measures, with all OpenMP threads (set OMP_NUM_THREADS to change):\n"
    "  nn      MLP layer kernels, own fused kernel vs oneDNN vs OpenBLAS, GFLOP/s\n"
    "  synth   path tracer samples/s on a fixed workload\n"
    "  render  primary-ray path as training runs it (march: sampling, fused SDF value+gradient,\n"
    "          alpha, kept list; feature grid, composite, backward) points/s and rays/s\n"
    "  train   a training run of every stage (alphamask, coarse, fine, lts, pdra) with the fast preset:\n"
    "          seconds and rays/s over each whole stage and over its last log window; on --data,\n"
    "          else ../shared/scenes/lamp when present, else a small `esr synth` scene in a temp\n"
    "          dir (full stages on lamp: about 9 minutes on 2 cores); each stage's time by part\n"
    "          (march, fields, MLP forward and backward, composite, LTS secondary rays and loss,\n"
    "          pdra, regularisers, Adam, other), the MLPs' GFLOP/s against oneDNN's sgemm of their\n"
    "          shape and Adam's GB/s against a parallel copy, both measured in the same run\n"
    "  lts     the LTS incident-radiance estimators on the trained pdra checkpoint (or --run's):\n"
    "          time per LTS call, secondary rays/s, and bias and standard deviation of the\n"
    "          estimate L^_o against the faithful estimator with 4096 directions (relative RMS)\n"
    "and the peak resident memory, with the machine (CPU model, cores, threads, the code paths its\n"
    "kernels picked), git commit and date. Prints a table and writes the JSON to --out.\n",
    .options = bench_options,
    .run = run_bench,
    .view_loop = 1,
};

/* "model name" of the first processor in /proc/cpuinfo, or "unknown". */
static void cpu_model(char *out, size_t n)
{
    snprintf(out, n, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':');
        if (!strncmp(line, "model name", 10) && colon) {
            colon += 1 + (colon[1] == ' ');
            colon[strcspn(colon, "\n")] = '\0';
            snprintf(out, n, "%s", colon);
            break;
        }
    }
    fclose(f);
}

/* Output of `git rev-parse HEAD` in the current directory, or "" outside a checkout. */
static void git_commit(char *out, size_t n)
{
    out[0] = '\0';
    FILE *p = popen("git rev-parse HEAD 2>/dev/null", "r");
    if (!p)
        return;
    if (!fgets(out, (int)n, p))
        out[0] = '\0';
    out[strcspn(out, "\n")] = '\0';
    pclose(p);
}

static cJSON *machine_json(void)
{
    char cpu[256], commit[64], date[32];
    time_t now = time(NULL);
    strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", gmtime(&now));
    cpu_model(cpu, sizeof cpu);
    git_commit(commit, sizeof commit);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "cpu", cpu);
    cJSON_AddNumberToObject(o, "cores", (double)sysconf(_SC_NPROCESSORS_ONLN));
    cJSON_AddNumberToObject(o, "omp_threads", omp_get_max_threads());
    cJSON_AddStringToObject(o, "git_commit", commit);
    cJSON_AddStringToObject(o, "date", date);
    cJSON_AddStringToObject(o, "mlp_kernels", esr_gemm_isa());
    cJSON_AddStringToObject(o, "hot_loops", esr_hot_loops_isa());
    cJSON_AddStringToObject(o, "max_isa", esr_isa_name(esr_isa_cap())); /* ESR_MAX_ISA */
    printf("machine: %s, %ld cores, %d OpenMP threads, commit %.12s, %s\n", cpu, sysconf(_SC_NPROCESSORS_ONLN),
           omp_get_max_threads(), commit[0] ? commit : "-", date);
    printf("code paths: MLP kernels %s, hot loops %s%s%s\n", esr_gemm_isa(), esr_hot_loops_isa(),
           esr_isa_cap() < ESR_ISA_AVX512 ? ", oneDNN and the MLP kernels capped by ESR_MAX_ISA=" : "",
           esr_isa_cap() < ESR_ISA_AVX512 ? esr_isa_name(esr_isa_cap()) : "");
    return o;
}

static int nn_section(const struct bench_opts *o, cJSON *root)
{
    struct esr_nn_bench_result r;
    ESR_TRY(esr_nn_bench(o->quick ? 1 : 3, &r));
    cJSON *rows = cJSON_AddArrayToObject(root, "nn");
    printf("\nMLP kernels (%d threads)\n%-9s %-4s %7s  %-16s %9s %9s\n", r.threads, "kernel", "pass", "n",
           "in-width*hid-out", "ms", "GFLOP/s");
    for (int i = 0; i < r.n_rows; i++) {
        const struct esr_nn_bench_row *w = &r.rows[i];
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "kernel", w->kernel);
        cJSON_AddStringToObject(row, "pass", w->pass);
        cJSON_AddNumberToObject(row, "n", w->n);
        cJSON_AddNumberToObject(row, "n_in", w->n_in);
        cJSON_AddNumberToObject(row, "width", w->width);
        cJSON_AddNumberToObject(row, "n_hidden", w->n_hidden);
        cJSON_AddNumberToObject(row, "n_out", w->n_out);
        cJSON_AddNumberToObject(row, "ms", w->ms);
        cJSON_AddNumberToObject(row, "gflops", w->gflops);
        cJSON_AddItemToArray(rows, row);
        char shape[64];
        snprintf(shape, sizeof shape, "%d-%dx%d-%d", w->n_in, w->width, w->n_hidden, w->n_out);
        printf("%-9s %-4s %7d  %-16s %9.3f %9.1f\n", w->kernel, w->pass, w->n, shape, w->ms, w->gflops);
    }
    return ESR_OK;
}

static int synth_section(cJSON *root)
{
    struct esr_synth_bench_result r;
    ESR_TRY(esr_synth_bench(&r));
    cJSON *o = cJSON_AddObjectToObject(root, "synth");
    cJSON_AddNumberToObject(o, "samples_per_s", r.samples_per_s);
    cJSON_AddNumberToObject(o, "pixels_per_s", r.pixels_per_s);
    cJSON_AddNumberToObject(o, "seconds", r.seconds);
    printf("\npath tracer: %.3f Msamples/s, %.0f pixels/s (%.2f s)\n", r.samples_per_s * 1e-6, r.pixels_per_s,
           r.seconds);
    return ESR_OK;
}

static int render_section(const struct bench_opts *o, cJSON *root)
{
    struct esr_render_bench_result r;
    ESR_TRY(esr_render_bench(o->quick ? 4096 : 16384, o->quick ? 1 : 3, &r));
    cJSON *j = cJSON_AddObjectToObject(root, "render");
    cJSON_AddNumberToObject(j, "rays", r.n_rays);
    cJSON_AddNumberToObject(j, "samples", r.samples);
    cJSON_AddNumberToObject(j, "kept", r.kept);
    cJSON_AddNumberToObject(j, "fwd_points_per_s", r.fwd_points_per_s);
    cJSON_AddNumberToObject(j, "total_points_per_s", r.total_points_per_s);
    cJSON_AddNumberToObject(j, "rays_per_s", r.rays_per_s);
    cJSON *ms = cJSON_AddObjectToObject(j, "ms");
    printf("\nray path, the training code without the MLPs (%d rays, %.0f samples, %.0f kept, %d "
           "threads)\n",
           r.n_rays, r.samples, r.kept, r.threads);
    for (int s = 0; s < ESR_RENDER_BENCH_STAGE_COUNT; s++) {
        cJSON_AddNumberToObject(ms, esr_render_bench_stage_name(s), r.ms[s]);
        printf("  %-10s %9.3f ms  %8.2f Mpoints/s\n", esr_render_bench_stage_name(s), r.ms[s],
               r.ms[s] > 0 ? r.samples / r.ms[s] * 1e-3 : 0.0);
    }
    printf("  forward %.2f Mpoints/s, forward+backward %.2f Mpoints/s, %.0f rays/s\n",
           r.fwd_points_per_s * 1e-6, r.total_points_per_s * 1e-6, r.rays_per_s);
    return ESR_OK;
}

/* run's last emitter-stage checkpoint (pdra, else lts) into ckpt; 0 when it has neither. */
static int emitter_checkpoint(const char *run, char ckpt[4200])
{
    snprintf(ckpt, 4200, "%s/ckpt_pdra.bin", run);
    if (!esr_file_exists(ckpt))
        snprintf(ckpt, 4200, "%s/ckpt_lts.bin", run);
    return esr_file_exists(ckpt);
}

/* The LTS estimators on run's last emitter-stage checkpoint, into root's "lts_estimators" (name
 * given for the JSON's "checkpoint"). */
static int lts_section(const char *run, const char *data, int repeats, cJSON *root)
{
    char ckpt[4200];
    emitter_checkpoint(run, ckpt);
    struct esr_bench_lts_result r;
    ESR_TRY(esr_bench_lts(ckpt, data, repeats, &r));
    cJSON *j = cJSON_AddObjectToObject(root, "lts_estimators");
    cJSON_AddStringToObject(j, "checkpoint", ckpt);
    cJSON_AddStringToObject(j, "stage", r.stage);
    cJSON_AddNumberToObject(j, "points", r.points);
    cJSON_AddNumberToObject(j, "calls", r.repeats);
    cJSON_AddNumberToObject(j, "reference_dirs", r.ref_dirs);
    cJSON_AddNumberToObject(j, "reference_rms_off", r.ref_rms_off);
    cJSON_AddNumberToObject(j, "reference_rms_emo", r.ref_rms_emo);
    printf("\nLTS estimators (%s checkpoint %s, %d points, %d calls each; bias and sd relative to\n"
           "the RMS of the faithful estimate with %d directions: off %.4g, emo %.4g)\n",
           r.stage, ckpt, r.points, r.repeats, r.ref_dirs, r.ref_rms_off, r.ref_rms_emo);
    printf("  %-22s %8s %11s %5s %9s %7s %7s %9s %7s %7s\n", "estimator", "ms/call", "secondary/s",
           "hit", "bias off", "(noise)", "sd off", "bias emo", "(noise)", "sd emo");
    cJSON *rows = cJSON_AddArrayToObject(j, "rows");
    for (int i = 0; i < r.n_rows; i++) {
        const struct esr_bench_lts_row *w = &r.rows[i];
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "name", w->name);
        cJSON_AddNumberToObject(row, "estimator", w->estimator);
        cJSON_AddNumberToObject(row, "dirs", w->dirs);
        cJSON_AddNumberToObject(row, "ms_per_call", w->ms_per_call);
        cJSON_AddNumberToObject(row, "secondary_rays_per_s", w->secondary_per_s);
        cJSON_AddNumberToObject(row, "hit_frac", w->hit_frac);
        cJSON_AddNumberToObject(row, "bias_off", w->bias_off);
        cJSON_AddNumberToObject(row, "sd_off", w->sd_off);
        cJSON_AddNumberToObject(row, "bias_emo", w->bias_emo);
        cJSON_AddNumberToObject(row, "sd_emo", w->sd_emo);
        cJSON_AddItemToArray(rows, row);
        cJSON_AddNumberToObject(row, "bias_noise_off", w->noise_off);
        cJSON_AddNumberToObject(row, "bias_noise_emo", w->noise_emo);
        printf("  %-22s %8.1f %11.0f %4.0f%% %9.4f %7.4f %7.4f %9.4f %7.4f %7.4f\n", w->name,
               w->ms_per_call, w->secondary_per_s, 100.0 * w->hit_frac, w->bias_off, w->noise_off,
               w->sd_off, w->bias_emo, w->noise_emo, w->sd_emo);
    }
    return ESR_OK;
}

/* One radiance fine-tune (edit/finetune.h: every light at half strength, default options) and
 * one lights-on view of the result, into root's "relight_finetune". */
static int finetune_timing(struct esr_model *m, const struct esr_dataset *ds, cJSON *root)
{
    struct esr_finetune_opts o;
    esr_finetune_default_opts(&o);
    struct esr_editor ed;
    ESR_TRY(esr_editor_init(&ed, m, ds, ESR_EDIT_FINETUNE, 8, &o)); /* 8: esr edit's --spp */
    struct esr_light_edit half[ESR_MAX_LIGHTS];
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        half[k] = (struct esr_light_edit){0.5f, 0, 0.0f, 0.0f};
    int rc = esr_editor_set(&ed, half, 1);
    struct esr_image img = {0};
    const struct esr_camera *c = &ds->phases[ESR_PHASE_TEST_NV].frames[0].camera;
    const double t0 = omp_get_wtime();
    if (rc == ESR_OK)
        rc = esr_editor_view(&ed, c, 0, &img);
    const double view_s = omp_get_wtime() - t0;
    esr_image_free(&img);
    if (rc == ESR_OK) {
        const double secs = ed.finetune_seconds;
        cJSON *j = cJSON_AddObjectToObject(root, "relight_finetune");
        cJSON_AddNumberToObject(j, "steps", o.iters);
        cJSON_AddNumberToObject(j, "points", o.points);
        cJSON_AddNumberToObject(j, "dirs", o.dirs);
        cJSON_AddNumberToObject(j, "light_spp", o.light_spp);
        cJSON_AddNumberToObject(j, "seconds_per_edit", secs);
        cJSON_AddNumberToObject(j, "secondary_rays_per_s",
                                secs > 0 ? (double)o.iters * o.points * o.dirs / secs : 0.0);
        cJSON_AddNumberToObject(j, "seconds_per_view", view_s);
        printf("finetune relight: %.1f s per distinct edit (%d steps of %d points x %d directions, "
               "%d light samples), then %.3f s per %dx%d view\n",
               secs, o.iters, o.points, o.dirs, o.light_spp, view_s, c->width, c->height);
    }
    esr_editor_free(&ed);
    return rc;
}

/* Seconds per relit view (after a warm-up view) of cam, all lights as found, by the direct
 * (ratio 0) or the ratio method (edit/relight.h), into root's "relight_direct" / "relight_ratio";
 * and per view as light groups (esr_relight_layers, what `esr lightmix` renders), beside it. */
static int relight_timing(const char *run, const struct esr_model *m, const struct esr_camera *c,
                          int ratio, cJSON *root)
{
    struct esr_relight rl;
    struct esr_light_edit edits[ESR_MAX_LIGHTS];
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        edits[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
    const int spp = 8, reps = 3;
    const double t_init = omp_get_wtime();
    ESR_TRY(esr_relight_init(&rl, m, spp, ratio ? ESR_RELIGHT_RATIO : ESR_RELIGHT_DIRECT));
    const double init_s = omp_get_wtime() - t_init;
    double secs = 0.0, direct_s = 0.0, shadow_rays = 0.0, layers_s = 0.0;
    int rc = ESR_OK;
    for (int i = 0; rc == ESR_OK && i <= reps; i++) {
        struct esr_image img;
        struct esr_relight_stats st;
        const double t0 = omp_get_wtime();
        rc = esr_relight_view(&rl, m, edits, c, (uint64_t)i, &img, &st);
        if (i > 0) { /* the first view warms up */
            secs += omp_get_wtime() - t0;
            direct_s += st.direct_seconds;
            shadow_rays += (double)st.shadow_rays;
        }
        esr_image_free(&img);
        struct esr_relight_layers L;
        const double t1 = omp_get_wtime();
        if (rc == ESR_OK && (rc = esr_relight_layers(&rl, m, c, (uint64_t)i, &L, NULL)) == ESR_OK)
            esr_relight_layers_free(&L);
        if (i > 0)
            layers_s += omp_get_wtime() - t1;
    }
    esr_relight_free(&rl);
    if (rc != ESR_OK)
        return rc;
    const char *name = ratio ? "ratio" : "direct";
    char key[32];
    snprintf(key, sizeof key, "relight_%s", name);
    cJSON *j = cJSON_AddObjectToObject(root, key);
    cJSON_AddNumberToObject(j, "width", c->width);
    cJSON_AddNumberToObject(j, "height", c->height);
    cJSON_AddNumberToObject(j, "lights", m->lights.n);
    cJSON_AddNumberToObject(j, "spp", spp);
    cJSON_AddNumberToObject(j, "seconds_per_view", secs / reps);
    cJSON_AddNumberToObject(j, "setup_seconds", init_s);
    cJSON_AddNumberToObject(j, "shadow_rays_per_view", shadow_rays / reps);
    cJSON_AddNumberToObject(j, "direct_light_seconds_per_view", direct_s / reps);
    cJSON_AddNumberToObject(j, "shadow_rays_per_s", direct_s > 0 ? shadow_rays / direct_s : 0.0);
    cJSON_AddNumberToObject(j, "light_groups_seconds_per_view", layers_s / reps);
    printf("\n%s relight (%s): %dx%d view, %d lights, %d light samples per pixel: %.3f s per view "
           "(setup %.2f s once); its direct light %.3f s: %.0fk shadow rays, %.0fk per s with "
           "sampling and BRDF\n",
           name, run, c->width, c->height, m->lights.n, spp, secs / reps, init_s, direct_s / reps,
           shadow_rays / reps / 1e3, direct_s > 0 ? shadow_rays / direct_s / 1e3 : 0.0);
    printf("%s light groups (esr lightmix's layers, off and 2 per light): %.3f s per view, %.2fx "
           "the relit view\n", name, layers_s / reps, secs > 0 ? layers_s / secs : 0.0);
    return ESR_OK;
}

/* The relights of the first test_nv view of run (direct, ratio) and a fine-tune, into root. */
static int relight_section(const char *run, const char *data, cJSON *root)
{
    char ckpt[4200];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", run);
    if (!esr_file_exists(ckpt))
        return ESR_OK;
    struct esr_model m;
    ESR_TRY(esr_model_load(&m, ckpt));
    struct esr_dataset ds;
    memset(&ds, 0, sizeof ds);
    int rc = m.lights.n > 0 ? esr_dataset_load(data, &ds) : ESR_OK;
    const struct esr_phase *ph = &ds.phases[ESR_PHASE_TEST_NV];
    if (rc != ESR_OK || m.lights.n == 0 || !ph->present || ph->n_frames < 1) {
        esr_dataset_free(&ds);
        esr_model_free(&m);
        return rc;
    }
    for (int ratio = 0; rc == ESR_OK && ratio < 2; ratio++)
        rc = relight_timing(run, &m, &ph->frames[0].camera, ratio, root);
    if (rc == ESR_OK)
        rc = finetune_timing(&m, &ds, root);
    esr_dataset_free(&ds);
    esr_model_free(&m);
    return rc;
}

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st, (void)flag, (void)ftw;
    return remove(path);
}

/* Dataset for the training benchmark: --data, the shared lamp scene, or a synthetic one. */
static int train_dataset(const struct bench_opts *o, const char *tmp, char *out, size_t n, const char **what)
{
    if (o->data) {
        snprintf(out, n, "%s", o->data);
        *what = "--data";
        return ESR_OK;
    }
    snprintf(out, n, "../shared/scenes/lamp");
    *what = "shared lamp scene";
    char probe[4200];
    snprintf(probe, sizeof probe, "%s/transforms/transforms_train.json", out);
    if (esr_file_exists(probe))
        return ESR_OK;
    snprintf(out, n, "%s/synth", tmp);
    *what = "esr synth default scene, 64x64";
    struct esr_synth_options so;
    memset(&so, 0, sizeof so);
    so.scene = "default";
    so.res = 64;
    so.spp = 4;
    so.seed = 1;
    return esr_synth_write_dataset(out, &so);
}

/* Where a stage's time went, part by part, each part's rate beside the machine's ceiling. */
static void stage_profile(const struct esr_prof_totals *p, double seconds,
                          const struct esr_bench_ceiling *ceil, cJSON *st)
{
    cJSON *parts = cJSON_AddObjectToObject(st, "parts");
    double sum = 0.0;
    for (int i = 0; i < ESR_PROF_PARTS; i++)
        sum += p->seconds[i];
    if (sum <= 0.0)
        return;
    for (int i = 0; i < ESR_PROF_PARTS; i++) {
        const double s = p->seconds[i];
        if (s <= 0.0)
            continue;
        cJSON *q = cJSON_AddObjectToObject(parts, esr_prof_part_name((enum esr_prof_part)i));
        cJSON_AddNumberToObject(q, "seconds", s);
        char rate[96] = "";
        if (p->flops[i] > 0.0) {
            const double g = p->flops[i] / s / 1e9;
            cJSON_AddNumberToObject(q, "gflops", g);
            cJSON_AddNumberToObject(q, "of_sgemm_mlp_shape", g / ceil->sgemm_mlp_gflops);
            snprintf(rate, sizeof rate, "%6.1f GFLOP/s, %3.0f%% of sgemm at its shape", g,
                     100.0 * g / ceil->sgemm_mlp_gflops);
        } else if (p->bytes[i] > 0.0) {
            const double g = p->bytes[i] / s / 1e9;
            cJSON_AddNumberToObject(q, "gbs", g);
            cJSON_AddNumberToObject(q, "of_copy", g / ceil->copy_gbs);
            snprintf(rate, sizeof rate, "%6.1f GB/s (nominal), %3.0f%% of a copy", g,
                     100.0 * g / ceil->copy_gbs);
        }
        printf("  %-10s   %-20s %7.2f s %5.1f%%  %s\n", "", esr_prof_part_name((enum esr_prof_part)i), s,
               100.0 * s / seconds, rate);
    }
    /* the parts count inside the training steps only (ESR_PROF_STEPS): other is the steps'
     * time in no part (batch draw, loss, bookkeeping); outside the steps is the rest of the
     * stage (start-up, checkpoints, the environment's start, the lights' estimation) */
    const double other = p->step_seconds - sum, outside = seconds - p->step_seconds;
    cJSON_AddNumberToObject(parts, "other_seconds", other);
    cJSON_AddNumberToObject(st, "step_seconds", p->step_seconds);
    cJSON_AddNumberToObject(st, "steps", (double)p->steps);
    cJSON_AddNumberToObject(st, "outside_steps_seconds", outside);
    printf("  %-10s   %-20s %7.2f s %5.1f%%  (in the steps, in no part: batch draw, loss, bookkeeping)\n", "",
           "other", other, 100.0 * other / seconds);
    printf("  %-10s   %-20s %7.2f s %5.1f%%  (start-up, checkpoints, the lights' estimation)\n", "",
           "outside the steps", outside, 100.0 * outside / seconds);
    /* what a faster MLP cannot touch: the stage's time outside the MLPs' forward and backward */
    const double mlp = p->seconds[ESR_PROF_MLP_FWD] + p->seconds[ESR_PROF_MLP_BWD];
    cJSON_AddNumberToObject(st, "outside_mlp_share", (seconds - mlp) / seconds);
    printf("  %-10s   %-20s %7.2f s %5.1f%%  (of the whole stage)\n", "", "outside the MLPs",
           seconds - mlp, 100.0 * (seconds - mlp) / seconds);
}

static int train_section(const struct bench_opts *o, cJSON *root)
{
    char tmp[] = "/tmp/esr-bench-XXXXXX", data[4096], run[sizeof tmp + 8];
    if (!mkdtemp(tmp))
        return ESR_FAIL("cannot create a temporary directory for the training benchmark");
    const char *what;
    struct esr_bench_train_result r;
    int iters = o->iters >= 0 ? o->iters : o->quick ? 40 : 0;
    snprintf(run, sizeof run, "%s/run", tmp);
    struct esr_bench_ceiling ceiling;
    const struct esr_bench_ceiling *ceil = &ceiling;
    int status = esr_bench_ceiling_measure(&ceiling);
    if (status == ESR_OK)
        status = train_dataset(o, tmp, data, sizeof data, &what);
    if (status == ESR_OK)
        status = esr_bench_train(data, run, iters, &r);
    /* the estimators on the checkpoint just trained, before it is removed */
    if (status == ESR_OK && !o->run)
        status = lts_section(run, data, o->quick ? 4 : 8, root);
    nftw(tmp, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
    ESR_TRY(status);
    cJSON *j = cJSON_AddObjectToObject(root, "train");
    cJSON_AddStringToObject(j, "dataset", data);
    cJSON *cj = cJSON_AddObjectToObject(j, "ceiling");
    cJSON_AddNumberToObject(cj, "sgemm_gflops", ceil->sgemm_gflops);
    cJSON_AddNumberToObject(cj, "sgemm_mlp_shape_gflops", ceil->sgemm_mlp_gflops);
    cJSON_AddNumberToObject(cj, "copy_gbs", ceil->copy_gbs);
    printf("\nceilings: oneDNN sgemm %.1f GFLOP/s (1024^3), %.1f GFLOP/s (65536 x 64 x 64); copy "
           "%.1f GB/s\n", ceil->sgemm_gflops, ceil->sgemm_mlp_gflops, ceil->copy_gbs);
    if (iters > 0)
        printf("\ntraining (%s: %s, %d iterations per stage)\n", what, data, iters);
    else
        printf("\ntraining (%s: %s, full fast-preset stages)\n", what, data);
    for (int s = 0; s < ESR_STAGE_COUNT; s++) {
        const struct esr_bench_train_stage *t = &r.stages[s];
        cJSON *st = cJSON_AddObjectToObject(j, esr_stage_name((enum esr_stage)s));
        cJSON_AddNumberToObject(st, "iters", t->iters);
        cJSON_AddNumberToObject(st, "batch_rays", t->batch_rays);
        cJSON_AddNumberToObject(st, "seconds", t->seconds);
        cJSON_AddNumberToObject(st, "rays_per_s", t->rays_per_s);
        cJSON_AddNumberToObject(st, "last_window_rays_per_s", t->last_rays_per_s);
        cJSON_AddNumberToObject(st, "samples_per_ray", t->samples_per_ray);
        cJSON_AddNumberToObject(st, "kept_per_ray", t->kept_per_ray);
        if (t->secondary_per_s > 0)
            cJSON_AddNumberToObject(st, "secondary_rays_per_s", t->secondary_per_s);
        printf("  %-10s %6d iters %7.1f s %8.0f rays/s (last window %.0f; %d rays/iter, %.1f "
               "samples/ray, %.1f kept)\n",
               esr_stage_name((enum esr_stage)s), t->iters, t->seconds, t->rays_per_s,
               t->last_rays_per_s, t->batch_rays, t->samples_per_ray, t->kept_per_ray);
        if (t->secondary_per_s > 0)
            printf("  %-10s secondary rays (first-hit estimator) %.0f/s over the last window\n", "",
                   t->secondary_per_s);
        stage_profile(&t->prof, t->seconds, ceil, st);
    }
    return ESR_OK;
}

/* Runs the sections into root, then writes it to o->out (root is consumed in every case). */
static int bench_all(const struct bench_opts *o, cJSON *root)
{
    cJSON_AddItemToObject(root, "machine", machine_json());
    cJSON_AddBoolToObject(root, "quick", o->quick);
    fflush(stdout);
    int sections = nn_section(o, root);
    fflush(stdout);
    if (sections == ESR_OK)
        sections = synth_section(root);
    if (sections == ESR_OK)
        sections = render_section(o, root);
    fflush(stdout);
    if (sections == ESR_OK && !o->no_train)
        sections = train_section(o, root);
    if (sections == ESR_OK && o->run) {
        char data[4096];
        sections = esr_run_data_dir(o->run, o->data, data, sizeof data);
        if (sections == ESR_OK)
            sections = lts_section(o->run, data, o->quick ? 4 : 8, root);
        if (sections == ESR_OK)
            sections = relight_section(o->run, data, root);
    }
    if (sections != ESR_OK) {
        cJSON_Delete(root);
        return sections;
    }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    cJSON_AddNumberToObject(root, "peak_rss_mb", (double)ru.ru_maxrss / 1024.0); /* ru_maxrss is in KiB */
    printf("\npeak memory %.1f MiB\n", (double)ru.ru_maxrss / 1024.0);
    int status = esr_json_write_atomic(o->out, root);
    if (status == ESR_OK)
        printf("wrote %s\n", o->out);
    return status;
}

/* The first problem esr_dataset_check reports. */
static void first_problem(void *user, const char *message)
{
    char *first = user;
    if (!first[0])
        snprintf(first, 1024, "%s", message);
}

/* A dataset whose JSON loads and whose every file decodes at its size (what `esr info` checks,
 * under a second for lamp). */
static int check_dataset(const char *dir)
{
    struct esr_dataset ds;
    ESR_TRY(esr_dataset_load(dir, &ds));
    char first[1024] = "";
    const int problems = esr_dataset_check(&ds, first_problem, first);
    esr_dataset_free(&ds);
    if (problems < 0)
        return ESR_ERR;
    if (problems > 0)
        return ESR_FAIL("dataset %s: %s (%d problem%s; `esr info %s` lists them)", dir, first,
                        problems, problems == 1 ? "" : "s", dir);
    return ESR_OK;
}

/* What would otherwise fail only after minutes of measuring: the output file, --data's
 * dataset, and --run's checkpoint (loaded) and dataset. */
static int check_inputs(const struct bench_opts *o)
{
    ESR_TRY(esr_file_check_writable(o->out));
    if (o->data)
        ESR_TRY(check_dataset(o->data));
    if (!o->run)
        return ESR_OK;
    char ckpt[4200], data[4096];
    if (!emitter_checkpoint(o->run, ckpt))
        return ESR_FAIL("--run: '%s' has no pdra or lts checkpoint (ckpt_pdra.bin, ckpt_lts.bin)",
                        o->run);
    struct esr_model m;
    ESR_TRY(esr_model_load(&m, ckpt));
    esr_model_free(&m);
    ESR_TRY(esr_run_data_dir(o->run, o->data, data, sizeof data));
    return o->data ? ESR_OK : check_dataset(data);
}

static int run_bench(int argc, char **argv)
{
    struct bench_opts o = {"bench.json", NULL, NULL, 0, 0, -1};
    const int parsed = cli_parse(&cmd_bench, argc, argv, &o);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    if (check_inputs(&o) != ESR_OK)
        return cli_fail_lib(&cmd_bench);
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return cli_fail(&cmd_bench, "out of memory");
    int status = bench_all(&o, root);
    return status == ESR_OK ? 0 : cli_fail_lib(&cmd_bench);
}
