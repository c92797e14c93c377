/* One option grammar (src/cli/options.c): every option a command parses is one its --help names
 * (the usage text is what the grammar accepts, so an option missing from it could not be
 * given); --name=value and the two spellings of colour reach the command as --name value; an
 * unknown option or command is answered with the nearest one. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/suggest.h"
#include "io/file.h"
#include "test_support.h"

static char out[1 << 17];

/* Every "--name" in a strcmp(x, "--name") of the source text. */
static int parsed_options(const char *src, char names[][48], int max)
{
    int n = 0;
    for (const char *p = strstr(src, "strcmp("); p && n < max; p = strstr(p + 1, "strcmp(")) {
        const char *close = strchr(p, ')'), *q = strstr(p, "\"--");
        if (!q || !close || q > close)
            continue;
        const size_t len = strcspn(q + 1, "\"");
        if (len < 3 || len >= 48)
            continue;
        memcpy(names[n], q + 1, len);
        names[n][len] = '\0';
        n++;
    }
    return n;
}

static void test_every_parsed_option_is_in_help(void **state)
{
    (void)state;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/cli", ESR_SOURCE_DIR);
    DIR *d = opendir(dir);
    assert_non_null(d);
    int commands = 0, checked = 0;
    for (struct dirent *e; (e = readdir(d));) {
        const size_t len = strlen(e->d_name);
        if (strncmp(e->d_name, "cmd_", 4) || len < 7 || strcmp(e->d_name + len - 2, ".c"))
            continue;
        char name[64], path[1200], args[128];
        snprintf(name, sizeof name, "%.*s", (int)(len - 6), e->d_name + 4);
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        unsigned char *src;
        size_t size;
        assert_int_equal(esr_file_read_all(path, &src, &size), 0);
        static char names[256][48];
        const int n = parsed_options((const char *)src, names, 256);
        free(src);
        snprintf(args, sizeof args, "%s --help", name);
        if (test_run_esr(args, out, sizeof out) != 0)
            fail_msg("esr %s failed:\n%s", args, out);
        commands++;
        for (int i = 0; i < n; i++, checked++)
            if (strcmp(names[i], "--help") && !strstr(out, names[i]))
                fail_msg("%s parses %s, which `esr %s --help` does not name", e->d_name, names[i], name);
    }
    closedir(d);
    print_message("%d commands, %d parsed options, each named by its --help\n", commands, checked);
    assert_true(commands >= 12);
    assert_true(checked >= 60);
}

static void test_grammar(void **state)
{
    (void)state;
    /* --name=value is --name value: the value reaches the command's own check */
    assert_int_equal(test_run_esr("edit RUN --light 0 --intensity=-1 --out x", out, sizeof out), 1);
    assert_non_null(strstr(out, "--intensity: expected a number >= 0"));
    assert_int_equal(test_run_esr("edit RUN --light 0 --colour=2,1 --out x", out, sizeof out), 1);
    assert_non_null(strstr(out, "--color: expected H,S with both in [0,1], got '2,1'"));
    assert_int_equal(test_run_esr("export RUN --no-color --resx 3", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown option '--resx' (did you mean --res?)"));
    assert_int_equal(test_run_esr("train DATA --out R --resme", out, sizeof out), 1);
    assert_non_null(strstr(out, "did you mean --resume?"));
    assert_int_equal(test_run_esr("trian DATA", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown command 'trian' (did you mean train?)"));
    assert_int_equal(test_run_esr("frobnicate", out, sizeof out), 1);
    assert_null(strstr(out, "did you mean"));
    assert_int_equal(test_run_esr("help nosuch", out, sizeof out), 1);
    assert_int_equal(test_run_esr("help edit", out, sizeof out), 0);
    assert_non_null(strstr(out, "usage: esr edit"));
}

static void test_suggest(void **state)
{
    (void)state;
    assert_int_equal(esr_edit_distance("orbt", "orbit"), 1);
    assert_int_equal(esr_edit_distance("ab", "ba"), 1); /* a swap is one edit */
    assert_int_equal(esr_edit_distance("", "abc"), 3);
    assert_int_equal(esr_edit_distance("kitten", "sitting"), 3);
    const char *c[] = {"--orbit", "--out", "--frames", NULL};
    assert_string_equal(esr_suggest("--orbt", c, 4), "--orbit");
    assert_string_equal(esr_suggest("--frame", c, 4), "--frames");
    assert_null(esr_suggest("--zzzzzz", c, 4));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_parsed_option_is_in_help),
        cmocka_unit_test(test_grammar),
        cmocka_unit_test(test_suggest),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
