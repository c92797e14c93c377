/* The source folders form layers, and an include may only point down (or within its own folder):
 *   0 core   1 io, nn   2 fields   3 volume, synth   4 model   5 train, render   6 edit
 *   7 eval   8 cli
 * core is plain maths and data; io/nn know nothing of fields; volume holds the rendering
 * primitives (rays, samplers, NeuS, compositing, first hit, marching cubes) that know no model;
 * model assembles the fields and the trace engine; train and render use a model; edit relights
 * a trained model with the lights train found; eval and cli sit on top. This test reads every source file under src/ and fails on an include that runs back
 * up (or sideways between two folders of the same layer), naming the file and the line. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <dirent.h>
#include <stdio.h>
#include <string.h>

#ifndef ESR_SOURCE_DIR
#error "ESR_SOURCE_DIR must name the repository's src/ folder"
#endif

struct layer {
    const char *folder;
    int rank;
};

static const struct layer layers[] = {
    {"core", 0},  {"io", 1},    {"nn", 1},     {"fields", 2}, {"volume", 3}, {"synth", 3},
    {"model", 4}, {"train", 5}, {"render", 5}, {"edit", 6},   {"eval", 7},   {"cli", 8},
};
#define N_LAYERS (sizeof layers / sizeof layers[0])

static int rank_of(const char *folder, size_t len)
{
    for (size_t i = 0; i < N_LAYERS; i++)
        if (strlen(layers[i].folder) == len && !strncmp(layers[i].folder, folder, len))
            return layers[i].rank;
    return -1;
}

/* 1 when `line` (one source line of a file in folder `from`) includes a project header of a
 * folder it may not use; *bad_rank is then that folder's rank (-1 for an unknown folder). */
static int include_violates(const char *from, const char *line, int *bad_rank)
{
    const char *p = strstr(line, "#include \"");
    if (!p || p != line + strspn(line, " \t"))
        return 0;
    p += strlen("#include \"");
    const char *slash = strchr(p, '/'), *quote = strchr(p, '"');
    if (!slash || !quote || slash > quote)
        return 0; /* a header of the same folder or a test helper */
    size_t len = (size_t)(slash - p);
    if (strlen(from) == len && !strncmp(from, p, len))
        return 0;
    int to = rank_of(p, len), mine = rank_of(from, strlen(from));
    *bad_rank = to;
    return to < 0 || mine < 0 || to >= mine;
}

static void test_checker_catches_upward_and_sideways_includes(void **state)
{
    (void)state;
    int r;
    assert_true(include_violates("volume", "#include \"model/model.h\"", &r));
    assert_true(include_violates("io", "#include \"nn/mlp.h\"", &r));          /* same layer */
    assert_true(include_violates("train", "#include \"render/view.h\"", &r));  /* same layer */
    assert_true(include_violates("core", "#include \"io/file.h\"", &r));
    assert_true(include_violates("fields", "#include \"nowhere/x.h\"", &r));   /* unknown */
    assert_false(include_violates("model", "#include \"volume/neus.h\"", &r));
    assert_false(include_violates("model", "#include \"model/trace.h\"", &r));
    assert_false(include_violates("cli", "#include \"eval/report.h\"", &r));
    assert_false(include_violates("core", "#include <math.h>", &r));
    assert_false(include_violates("core", "/* #include \"io/file.h\" in a comment */", &r));
}

static void test_every_source_include_points_down(void **state)
{
    (void)state;
    int violations = 0, files = 0;
    for (size_t i = 0; i < N_LAYERS; i++) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/%s", ESR_SOURCE_DIR, layers[i].folder);
        DIR *d = opendir(dir);
        assert_non_null(d);
        struct dirent *e;
        while ((e = readdir(d))) {
            size_t n = strlen(e->d_name);
            if (n < 3 || e->d_name[n - 2] != '.' || (e->d_name[n - 1] != 'c' && e->d_name[n - 1] != 'h'))
                continue;
            char path[8192];
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            FILE *f = fopen(path, "r");
            assert_non_null(f);
            files++;
            char line[1024];
            int lineno = 0, bad;
            while (fgets(line, sizeof line, f)) {
                lineno++;
                if (include_violates(layers[i].folder, line, &bad)) {
                    print_error("%s:%d: %s/ (layer %d) includes a header of layer %d: %s", path,
                                lineno, layers[i].folder, layers[i].rank, bad, line);
                    violations++;
                }
            }
            fclose(f);
        }
        closedir(d);
    }
    /* every folder under src/ must be in the table, so a new one cannot slip past the check */
    DIR *d = opendir(ESR_SOURCE_DIR);
    assert_non_null(d);
    struct dirent *e;
    while ((e = readdir(d)))
        if (e->d_name[0] != '.' && rank_of(e->d_name, strlen(e->d_name)) < 0) {
            print_error("src/%s: folder missing from the layer table in tests/test_layers.c\n",
                        e->d_name);
            violations++;
        }
    closedir(d);
    assert_true(files > 50);
    assert_int_equal(violations, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_checker_catches_upward_and_sideways_includes),
        cmocka_unit_test(test_every_source_include_points_down),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
