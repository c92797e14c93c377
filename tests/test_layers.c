/* The source folders form layers, and an include may only point down (or within its own folder):
 *   0 core   1 io, nn   2 fields, import   3 volume, synth   4 model   5 train, render   6 edit
 *   7 eval   8 cli
 * import turns photo captures into datasets with io alone (nothing that trains or renders);
 * core is plain maths and data; io/nn know nothing of fields; volume holds the rendering
 * primitives (rays, samplers, NeuS, compositing, first hit, marching cubes) that know no model;
 * model assembles the fields and the trace engine; train and render use a model; edit relights
 * a trained model with the lights train found; eval and cli sit on top. This test reads every source file under src/ and fails on an include that runs back
 * up (or sideways between two folders of the same layer), naming the file and the line. It also
 * holds the library to its promise (README, Source layout) that only cli prints or exits: outside
 * src/cli no code (comments aside) names stdout or stderr or calls printf, puts, putchar, perror,
 * exit or abort; the library reports through return codes, messages and callbacks. */
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
    {"core", 0},  {"io", 1},    {"nn", 1},     {"fields", 2}, {"import", 2}, {"volume", 3},
    {"synth", 3},
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

static int is_ident_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

/* 1 when code (not comment) text `code` names stdout/stderr or calls a printing or exiting
 * function; *what gets the name found. */
static int code_prints(const char *code, const char **what)
{
    static const char *const names[] = {"stdout", "stderr", "printf", "puts",
                                        "putchar", "perror", "exit", "abort"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        const size_t len = strlen(names[i]);
        for (const char *p = strstr(code, names[i]); p; p = strstr(p + 1, names[i])) {
            if (p > code && is_ident_char(p[-1]))
                continue; /* fprintf, snprintf, _exit: part of another name */
            const char *q = p + len;
            if (is_ident_char(*q))
                continue;
            const int stream = i < 2;
            while (*q == ' ')
                q++;
            if (stream || *q == '(') {
                *what = names[i];
                return 1;
            }
        }
    }
    return 0;
}

/* `line` without its comments into `code` (*in_comment: inside a block comment, carried from
 * line to line). String literals are kept: a message naming stderr would count. */
static void strip_comments(const char *line, int *in_comment, char *code, size_t cap)
{
    size_t n = 0;
    for (const char *p = line; *p && n + 1 < cap; p++) {
        if (*in_comment) {
            if (p[0] == '*' && p[1] == '/') {
                *in_comment = 0;
                p++;
            }
        } else if (p[0] == '/' && p[1] == '*') {
            *in_comment = 1;
            p++;
        } else if (p[0] == '/' && p[1] == '/') {
            break;
        } else {
            code[n++] = *p;
        }
    }
    code[n] = 0;
}

static void test_print_checker(void **state)
{
    (void)state;
    const char *w;
    char code[256];
    int in = 0;
    assert_true(code_prints("fprintf(stderr, \"x\");", &w));
    assert_true(code_prints("    printf(\"%d\", 1);", &w));
    assert_true(code_prints("exit (1);", &w));
    assert_true(code_prints("FILE *f = stdout;", &w));
    assert_false(code_prints("snprintf(buf, sizeof buf, \"%d\", 1);", &w));
    assert_false(code_prints("fprintf(out, \"%d\", 1);", &w));
    assert_false(code_prints("float exit = fminf(exit, t);", &w));
    assert_false(code_prints("__attribute__((format(printf, 3, 4)));", &w));
    assert_false(code_prints("_exit(1); my_abort(); stdout_lines++;", &w));
    strip_comments("x = 1; /* print to stderr */ y = 2; // exit(1)", &in, code, sizeof code);
    assert_false(code_prints(code, &w));
    assert_int_equal(in, 0);
    strip_comments("a(); /* starts here, stderr", &in, code, sizeof code);
    assert_int_equal(in, 1);
    strip_comments(" * still stderr */ abort();", &in, code, sizeof code);
    assert_true(code_prints(code, &w));
    assert_string_equal(w, "abort");
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

static void test_every_source_keeps_to_its_layer(void **state)
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
            char line[1024], code[1024];
            int lineno = 0, bad, in_comment = 0;
            const int library = strcmp(layers[i].folder, "cli") != 0;
            const char *what;
            while (fgets(line, sizeof line, f)) {
                lineno++;
                if (include_violates(layers[i].folder, line, &bad)) {
                    print_error("%s:%d: %s/ (layer %d) includes a header of layer %d: %s", path,
                                lineno, layers[i].folder, layers[i].rank, bad, line);
                    violations++;
                }
                strip_comments(line, &in_comment, code, sizeof code);
                if (library && code_prints(code, &what)) {
                    print_error("%s:%d: library code uses %s (only src/cli prints or exits): %s",
                                path, lineno, what, line);
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
        cmocka_unit_test(test_print_checker),
        cmocka_unit_test(test_every_source_keeps_to_its_layer),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
