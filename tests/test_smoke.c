/* The smoke preset end to end (`esr train --preset smoke` on a 32 px, 8-view dataset: every stage,
 * grids sized to the images, small checkpoints), and `esr lights` on the run it trains: the table
 * gives H, S, V next to R, G, B (checked against an RGB -> HSV written here), listing writes
 * nothing, --picture writes the picture at its stated size, and an interrupted --recompute
 * leaves the checkpoint, lights.json and lights.png as they were, with no file left aside.
 * Labelled "smoke" (tests/CMakeLists.txt): a few seconds on two idle cores. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <dirent.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "io/file.h"
#include "io/image.h"
#include "model/config.h"
#include "model/model.h"
#include "render/digit_font.h"
#include "render/lights_picture.h"
#include "core/colour.h"
#include "core/error.h"
#include "edit/relight.h"
#include "io/dataset.h"
#include "train/lights/solve.h"
#include "train/rays.h"
#include "test_support.h"

static char data_dir[4200], run_dir[4200];
static char out[1 << 16];

static const char *const stage_names[] = {"alphamask", "coarse", "fine", "lts", "pdra"};

static int setup(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    snprintf(data_dir, sizeof data_dir, "%s/data", test_tmpdir);
    snprintf(run_dir, sizeof run_dir, "%s/run", test_tmpdir);
    char args[4400];
    snprintf(args, sizeof args, "synth --res 32 --spp 4 --train 8 --test 2 '%s'", data_dir);
    return test_run_esr(args, out, sizeof out) == 0 ? 0 : -1;
}

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void test_smoke_trains_every_stage(void **state)
{
    (void)state;
    char args[9000], path[4400];
    snprintf(args, sizeof args, "train '%s' --out '%s' --preset smoke", data_dir, run_dir);
    const double t0 = now_s();
    const int rc = test_run_esr(args, out, sizeof out);
    const double secs = now_s() - t0;
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", args, rc, out);
    print_message("esr train --preset smoke: %.1f s\n", secs);
    /* the grids follow the images (32 px, 8 lights-off views: config.h's rule) and are logged */
    assert_non_null(strstr(out, "grids: alphamask.res 20, coarse.res 20, fine.res 32, lts.res 32, "
                                "pdra.res 32 (from the images: 32x32, 8192 pixels"));
    long total = 0;
    for (int s = 0; s < 5; s++) {
        char done[64];
        snprintf(done, sizeof done, "stage %s done", stage_names[s]);
        if (!strstr(out, done))
            fail_msg("no '%s' in:\n%s", done, out);
        snprintf(path, sizeof path, "%s/ckpt_%s.bin", run_dir, stage_names[s]);
        struct stat st;
        assert_int_equal(stat(path, &st), 0);
        total += (long)st.st_size;
    }
    print_message("checkpoints: %.1f MB\n", (double)total / 1e6);
    assert_true(total < 12 * 1000 * 1000); /* 128^3 grids made 490 MB */
    assert_non_null(strstr(out, "lights found: "));
    struct esr_model m;
    snprintf(path, sizeof path, "%s/ckpt_pdra.bin", run_dir);
    assert_int_equal(esr_model_load(&m, path), 0);
    assert_true(m.stage_done);
    assert_int_equal(m.cfg.preset, ESR_PRESET_SMOKE);
    assert_int_equal(m.cfg.fine.res, 32);
    assert_int_equal(m.cfg.coarse.res, 20);
    assert_true(m.lights.n >= 1);
    esr_model_free(&m);
    /* config.json records the resolved numbers, so a --resume builds the same grids */
    snprintf(path, sizeof path, "%s/config.json", run_dir);
    cJSON *cfg = test_read_json(path);
    assert_non_null(cfg);
    assert_string_equal(cJSON_GetObjectItem(cfg, "preset")->valuestring, "smoke");
    assert_int_equal(cJSON_GetObjectItem(cfg, "pdra.res")->valueint, 32);
    assert_int_equal(cJSON_GetObjectItem(cfg, "alphamask.res")->valueint, 20);
    cJSON_Delete(cfg);
}

/* Every entry of dir but ".." (and "." unless with_dot) as "name size mtime-ns inode" lines,
 * sorted: what a command that writes nothing must leave unchanged. The folder's own mtime moves
 * when a file is made and removed in it: a command that writes nothing leaves it too, one that
 * checks its outputs can be written before its work (a probe file) does not. */
static void dir_state_of(const char *dir, int with_dot, char *state, size_t n)
{
    struct dirent **names;
    const int count = scandir(dir, &names, NULL, alphasort);
    assert_true(count >= 0);
    state[0] = '\0';
    for (int i = 0; i < count; i++) {
        char path[4600];
        struct stat st;
        snprintf(path, sizeof path, "%s/%s", dir, names[i]->d_name);
        const int skip = !strcmp(names[i]->d_name, "..") || (!with_dot && !strcmp(names[i]->d_name, "."));
        if (!skip && stat(path, &st) == 0)
            snprintf(state + strlen(state), n - strlen(state), "%s %lld %lld.%09ld %llu\n",
                     names[i]->d_name, (long long)st.st_size, (long long)st.st_mtim.tv_sec,
                     st.st_mtim.tv_nsec, (unsigned long long)st.st_ino);
        free(names[i]);
    }
    free(names);
}

static void dir_state(const char *dir, char *state, size_t n)
{
    dir_state_of(dir, 1, state, n);
}

/* H, S, V of rgb written out from the definition (hexcone), not esr's function. */
static void hsv_of(const double rgb[3], double hsv[3])
{
    const double r = rgb[0], g = rgb[1], b = rgb[2];
    const double mx = fmax(r, fmax(g, b)), mn = fmin(r, fmin(g, b)), c = mx - mn;
    double h = 0.0;
    if (c > 0.0) {
        if (mx == r)
            h = fmod((g - b) / c + 6.0, 6.0);
        else if (mx == g)
            h = (b - r) / c + 2.0;
        else
            h = (r - g) / c + 4.0;
    }
    hsv[0] = h / 6.0;
    hsv[1] = mx > 0.0 ? c / mx : 0.0;
    hsv[2] = mx;
}

static double hue_distance(double a, double b)
{
    const double d = fabs(a - b);
    return fmin(d, 1.0 - d);
}

static void test_lights_table_has_hsv_and_writes_nothing(void **state)
{
    (void)state;
    char args[9000], before[8192], after[8192], path[4400];
    dir_state(run_dir, before, sizeof before);
    snprintf(args, sizeof args, "lights '%s'", run_dir);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("esr %s:\n%s", args, out);
    dir_state(run_dir, after, sizeof after);
    assert_string_equal(before, after); /* no lights.json, nothing touched */
    snprintf(path, sizeof path, "%s/lights.json", run_dir);
    assert_false(esr_file_exists(path));
    /* one header per number, and the units */
    const char *hdr = strstr(out, "  id        x       y       z     area         R        G        B"
                                  "      H     S        V     power  scale R scale G scale B\n");
    if (!hdr)
        fail_msg("no column header in:\n%s", out);
    assert_non_null(strstr(out, "`esr edit --color H,S`"));
    assert_non_null(strstr(out, "linear RGB on the photos' scale"));
    assert_non_null(strstr(out, "luminance(rgb) x pi x area"));
    assert_non_null(strstr(out, "world units^2"));

    struct esr_model m;
    snprintf(path, sizeof path, "%s/ckpt_pdra.bin", run_dir);
    assert_int_equal(esr_model_load(&m, path), 0);
    const char *row = strchr(hdr, '\n') + 1;
    for (int i = 0; i < m.lights.n; i++) {
        int id;
        double c[3], area, rgb[3], hsv[3], power, scale[3];
        const int got = sscanf(row, "%d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &id,
                               &c[0], &c[1], &c[2], &area, &rgb[0], &rgb[1], &rgb[2], &hsv[0],
                               &hsv[1], &hsv[2], &power, &scale[0], &scale[1], &scale[2]);
        if (got != 15)
            fail_msg("row %d does not read as 15 numbers (%d): %.200s", i, got, row);
        assert_int_equal(id, i);
        const struct esr_light *l = &m.lights.light[i];
        double want[3], exact[3];
        for (int a = 0; a < 3; a++) {
            exact[a] = l->radiance[a];
            assert_true(fabs(rgb[a] - exact[a]) <= 5e-3 * fmax(fabs(exact[a]), 1e-3));
        }
        hsv_of(exact, want);
        print_message("light %d: rgb %.4g %.4g %.4g -> hsv %.3f %.3f %.4g, listed %.3f %.3f %.4g\n", i,
                      exact[0], exact[1], exact[2], want[0], want[1], want[2], hsv[0], hsv[1], hsv[2]);
        assert_true(hue_distance(hsv[0], want[0]) <= 0.0006);
        assert_true(fabs(hsv[1] - want[1]) <= 0.0006);
        assert_true(fabs(hsv[2] - want[2]) <= 5e-3 * want[2]);
        row = strchr(row, '\n') + 1;
    }
    /* --json writes the same numbers, and only where asked */
    snprintf(path, sizeof path, "%s/listed.json", test_tmpdir);
    snprintf(args, sizeof args, "lights '%s' --json '%s'", run_dir, path);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    dir_state(run_dir, after, sizeof after);
    assert_string_equal(before, after);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    const cJSON *lights = cJSON_GetObjectItem(root, "lights");
    assert_int_equal(cJSON_GetArraySize(lights), m.lights.n);
    for (int i = 0; i < m.lights.n; i++) {
        const cJSON *l = cJSON_GetArrayItem(lights, i);
        double rgb[3], want[3];
        for (int a = 0; a < 3; a++)
            rgb[a] = cJSON_GetArrayItem(cJSON_GetObjectItem(l, "rgb"), a)->valuedouble;
        hsv_of(rgb, want);
        const cJSON *hsv = cJSON_GetObjectItem(l, "hsv");
        assert_true(hue_distance(cJSON_GetArrayItem(hsv, 0)->valuedouble, want[0]) < 1e-5);
        assert_true(fabs(cJSON_GetArrayItem(hsv, 1)->valuedouble - want[1]) < 1e-5);
        assert_true(fabs(cJSON_GetArrayItem(hsv, 2)->valuedouble - want[2]) < 1e-5 * want[2] + 1e-7);
    }
    assert_non_null(cJSON_GetObjectItem(cJSON_GetObjectItem(root, "units"), "power"));
    cJSON_Delete(root);
    esr_model_free(&m);
}

static void test_lights_picture(void **state)
{
    (void)state;
    char args[9000], before[8192], after[8192], path[4400];
    dir_state(run_dir, before, sizeof before);
    snprintf(path, sizeof path, "%s/where.png", test_tmpdir);
    snprintf(args, sizeof args, "lights '%s' --picture '%s'", run_dir, path);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("esr %s:\n%s", args, out);
    dir_state(run_dir, after, sizeof after);
    assert_string_equal(before, after);
    assert_non_null(strstr(out, "picture from training frame"));
    struct esr_image img;
    assert_int_equal(esr_png_read(path, &img), 0);
    /* the 32 px photo enlarged to the picture's minimum width */
    assert_int_equal(esr_lights_picture_scale(32), 8);
    assert_int_equal(img.width, 256);
    assert_int_equal(img.height, 256);
    /* the ids' black boxes: the photo on white has no black pixels of its own */
    long black = 0;
    for (size_t p = 0; p < (size_t)img.width * (size_t)img.height; p++) {
        const float *v = img.data + p * (size_t)img.channels;
        black += v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f;
    }
    print_message("picture: %ld black pixels\n", black);
    assert_true(black >= 100);
    esr_image_free(&img);
    /* refused before any work: not a PNG name, a missing folder */
    snprintf(args, sizeof args, "lights '%s' --picture '%s/where.jpg'", run_dir, test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "ending in .png"));
    snprintf(args, sizeof args, "lights '%s' --picture '%s/missing/where.png'", run_dir, test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "missing/where.png"));
    /* a slip that would write over the checkpoint */
    snprintf(args, sizeof args, "lights '%s' --json '%s/ckpt_pdra.bin'", run_dir, run_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "ending in .json"));
    dir_state(run_dir, after, sizeof after);
    assert_string_equal(before, after);
}

/* The ids' font: each digit its own pattern, boxes sized as said, nothing drawn outside them. */
static void test_digit_font(void **state)
{
    (void)state;
    int w, h;
    esr_digits_size(7, 2, &w, &h);
    assert_int_equal(w, 10);
    assert_int_equal(h, 14);
    esr_digits_size(15, 3, &w, &h);
    assert_int_equal(w, 27);
    assert_int_equal(h, 21);
    static const float fg[3] = {1, 1, 1}, bg[3] = {0, 0, 0};
    char seen[10][16];
    for (int d = 0; d < 10; d++) {
        struct esr_image img;
        assert_int_equal(esr_image_alloc(&img, 7, 9, 3), 0);
        for (size_t i = 0; i < esr_image_count(&img); i++)
            img.data[i] = 0.5f;
        esr_digits_draw(&img, 1, 1, d, 1, fg, bg); /* a 5 x 7 box at (1, 1) */
        int lit = 0;
        for (int y = 0; y < 9; y++)
            for (int x = 0; x < 7; x++) {
                const float v = img.data[(y * 7 + x) * 3];
                const int inside = x >= 1 && x < 6 && y >= 1 && y < 8;
                assert_true(inside ? v == 0.0f || v == 1.0f : v == 0.5f);
                if (x >= 2 && x < 5 && y >= 2 && y < 7) /* the glyph's 3 x 5 */
                    seen[d][lit++] = v == 1.0f ? '#' : '.';
            }
        seen[d][lit] = '\0';
        for (int e = 0; e < d; e++)
            if (!strcmp(seen[d], seen[e]))
                fail_msg("digits %d and %d look the same (%s)", e, d, seen[d]);
        esr_image_free(&img);
    }
    assert_string_equal(seen[1], ".#.##..#..#.###"); /* a 1 reads as one */
}

/* The signal mask this process's child `pid` catches (/proc/PID/status SigCgt); 0 when unread. */
static unsigned long long caught_signals(pid_t pid)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
    FILE *f = fopen(path, "r");
    unsigned long long mask = 0;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "SigCgt:", 7))
            mask = strtoull(line + 7, NULL, 16);
    if (f)
        fclose(f);
    return mask;
}

/* Runs `esr lights RUN --recompute`, sends sig as soon as it has taken over SIGINT and SIGTERM
 * (it then has the model to load and the lights to find and calibrate, about a second), and
 * returns its exit status; its output in log. */
static int recompute_interrupted(int sig, const char *log)
{
    const pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        FILE *f = freopen(log, "w", stdout);
        if (!f || dup2(fileno(stdout), 2) < 0)
            _exit(99);
        execl(ESR_BINARY, ESR_BINARY, "lights", run_dir, "--recompute", (char *)NULL);
        _exit(98);
    }
    const unsigned long long both = (1ull << (SIGINT - 1)) | (1ull << (SIGTERM - 1));
    const double t0 = now_s();
    while ((caught_signals(pid) & both) != both && now_s() - t0 < 30.0)
        usleep(500);
    kill(pid, sig);
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

static void test_lights_recompute_interrupted(void **state)
{
    (void)state;
    char args[9000], before[8192], after[8192], log[4400], path[4400];
    /* a completed recompute writes the three together */
    snprintf(args, sizeof args, "lights '%s' --recompute", run_dir);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("esr %s:\n%s", args, out);
    const char *files[] = {"ckpt_pdra.bin", "lights.json", "lights.png"};
    for (int i = 0; i < 3; i++) {
        snprintf(path, sizeof path, "%s/%s", run_dir, files[i]);
        assert_true(esr_file_exists(path));
        snprintf(path, sizeof path, "wrote %s/%s", run_dir, files[i]);
        assert_non_null(strstr(out, path));
    }
    dir_state_of(run_dir, 0, before, sizeof before);
    const int sigs[] = {SIGTERM, SIGINT};
    for (int i = 0; i < 2; i++) {
        snprintf(log, sizeof log, "%s/recompute_%d.log", test_tmpdir, sigs[i]);
        const int rc = recompute_interrupted(sigs[i], log);
        unsigned char *text = NULL;
        size_t size = 0;
        assert_int_equal(esr_file_read_all(log, &text, &size), 0);
        char said[8192];
        snprintf(said, sizeof said, "%.*s", (int)size, (const char *)text);
        free(text);
        if (rc != 128 + sigs[i])
            fail_msg("signal %d: exit %d, expected %d:\n%s", sigs[i], rc, 128 + sigs[i], said);
        assert_non_null(strstr(said, "the checkpoint, lights.json and lights.png are as they were"));
        /* the same files, not rewritten (inode and mtime), nothing left aside */
        dir_state_of(run_dir, 0, after, sizeof after);
        assert_string_equal(before, after);
    }
    /* and the run still loads and lists */
    snprintf(args, sizeof args, "lights '%s'", run_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
}

/* `esr lights --recompute --set` with a value out of its option's range is refused before
 * anything is found or written (the lock once took the place of the --set's failure). */
static void test_lights_set_refused(void **state)
{
    (void)state;
    char args[9000], before[8192], after[8192];
    dir_state_of(run_dir, 0, before, sizeof before); /* every file (the folder's own time moves
                                                      with the stale-temporary sweep) */
    snprintf(args, sizeof args, "lights '%s' --recompute --set lights_solve=7", run_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "out of range"));
    dir_state_of(run_dir, 0, after, sizeof after);
    assert_string_equal(before, after);
}

/* The strength solve inverts the direct relight: photos made by `esr edit --method direct`'s
 * renderer (edit/relight.c: its own layers, denoiser and light samples) from the trained model
 * with its lights at chosen strengths give those strengths back (train/lights/solve.h). The model
 * is the smoke run's (what it learned does not matter: the photos are its own); its lights light
 * little, so the strengths are mostly read off their own pixels (lights_solve_seen 1). And no
 * strength the run itself solved is absurd (an undertrained field lights almost nothing, which
 * the clipped pixels could lift without end). */
static void test_lights_solve_inverts_direct_relight(void **state)
{
    (void)state;
    struct esr_model m;
    assert_int_equal(esr_model_load_finished_pdra(&m, run_dir), ESR_OK);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(data_dir, &ds), ESR_OK);
    const int K = m.lights.n;
    assert_true(K >= 1);
    for (int k = 0; k < K; k++)
        for (int c = 0; c < 3; c++)
            assert_true(m.lights.light[k].radiance[c] >= 0.0f &&
                        m.lights.light[k].radiance[c] <= ESR_SOLVE_MAX_RADIANCE * 1.001f);
    float truth[ESR_MAX_LIGHTS][3];
    for (int k = 0; k < K; k++)
        for (int c = 0; c < 3; c++) { /* dim enough that few pixels clip */
            truth[k][c] = 0.3f + 0.2f * (float)((k + c) % 3) + 0.1f * (float)k;
            m.lights.light[k].scale[c] = truth[k][c];
        }
    const struct esr_phase *ph = &ds.phases[ESR_PHASE_TRAIN];
    size_t n = 0;
    for (int f = 0; f < ph->n_frames; f++)
        n += ph->frames[f].lights_on ? (size_t)ph->frames[f].camera.width * (size_t)ph->frames[f].camera.height : 0;
    struct esr_ray_set rs = {n, 0, malloc(n * 3 * sizeof(float)), malloc(n * 3 * sizeof(float)),
                             malloc(n * 3 * sizeof(float)), 0};
    assert_true(n > 0 && rs.orig3 && rs.dir3 && rs.rgb3);
    struct esr_relight r;
    assert_int_equal(esr_relight_init(&r, &m, 64, ESR_RELIGHT_DIRECT), ESR_OK);
    struct esr_light_edit edits[ESR_MAX_LIGHTS];
    for (int k = 0; k < K; k++)
        edits[k] = (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f};
    size_t at = 0;
    for (int f = 0; f < ph->n_frames; f++) {
        const struct esr_camera *cam = &ph->frames[f].camera;
        if (!ph->frames[f].lights_on)
            continue;
        struct esr_image img;
        assert_int_equal(esr_relight_view(&r, &m, edits, cam, 7 + (uint64_t)f, &img, NULL), ESR_OK);
        const size_t np = (size_t)cam->width * (size_t)cam->height;
        esr_camera_pixel_rays(cam, rs.orig3 + at * 3, rs.dir3 + at * 3);
        for (size_t i = 0; i < np * 3; i++) /* a photo: sRGB, clipped */
            rs.rgb3[at * 3 + i] = esr_srgb_from_linear(esr_clamp01(img.data[i]));
        at += np;
        esr_image_free(&img);
    }
    esr_relight_free(&r);
    for (int k = 0; k < K; k++)
        for (int c = 0; c < 3; c++)
            m.lights.light[k].scale[c] = 1.0f; /* the solve starts from the field */
    m.cfg.lights_solve_dirs = 0; /* the photos are the model's own: no base colour to correct */
    m.cfg.lights_solve_seen = 1; /* nor an edge to distrust: the lights' own pixels count */
    m.cfg.lights_solve_rays = 1 << 20;
    struct esr_lights_solve_info info;
    assert_int_equal(esr_lights_solve(&m, &rs, 3, &info), ESR_OK);
    int checked = 0;
    for (int k = 0; k < K; k++) {
        print_message("light %d: %ld rows, scale %g %g %g\n", k, info.light_rows[k],
                      (double)m.lights.light[k].scale[0], (double)m.lights.light[k].scale[1],
                      (double)m.lights.light[k].scale[2]);
        if (info.light_rows[k] < 300) /* a light too few pixels see says little */
            continue;
        for (int c = 0; c < 3; c++) {
            const double got = m.lights.light[k].scale[c];
            print_message("light %d channel %d: %.3f for %.3f (%ld rows)\n", k, c, got,
                          (double)truth[k][c], info.light_rows[k]);
            assert_true(fabs(got / truth[k][c] - 1.0) < 0.05);
        }
        checked++;
    }
    assert_true(checked >= 1);
    free(rs.orig3), free(rs.dir3), free(rs.rgb3);
    esr_dataset_free(&ds);
    esr_model_free(&m);
}

int main(void)
{
    /* OpenMP's workers spin at each barrier by default: with other jobs on the cores (ctest -j)
     * the smoke run took 32 s, passive 5.5 s; on two idle cores 1.6 s against 3 s passive */
    setenv("OMP_WAIT_POLICY", "passive", 1);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_smoke_trains_every_stage),
        cmocka_unit_test(test_lights_table_has_hsv_and_writes_nothing),
        cmocka_unit_test(test_digit_font),
        cmocka_unit_test(test_lights_picture),
        cmocka_unit_test(test_lights_recompute_interrupted),
        cmocka_unit_test(test_lights_solve_inverts_direct_relight),
        cmocka_unit_test(test_lights_set_refused),
    };
    return cmocka_run_group_tests(tests, setup, test_teardown_tmpdir);
}
