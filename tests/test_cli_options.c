/* Every command's option table (src/cli/option_table.h) is both what --help lists and what the
 * parser accepts: each table option has its row in `esr CMD --help` and every row is a table
 * option; the parser takes each one as the table says (a value option without its value, a flag
 * given one, are refused naming it) and refuses a near miss with the nearest; no command
 * compares its arguments with option names itself. And the shared grammar: --name=value, both
 * spellings of colour, an unknown option or command answered with the nearest one. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/suggest.h"
#include "io/file.h"
#include "test_support.h"

static char out[1 << 17];

static int is_option(const struct cli_option *o)
{
    return o->name[0] == '-';
}

/* The options part of a command's --help (from "\noptions:\n" on), or NULL. */
static const char *options_section(const char *help)
{
    const char *s = strstr(help, "\noptions:\n");
    return s ? s + strlen("\noptions:\n") : NULL;
}

/* 1 when the section (from the newline before its first row) has a row "  LABEL": LABEL
 * followed by a space or the end of the line. */
static int has_row(const char *section, const char *label)
{
    char row[160];
    snprintf(row, sizeof row, "\n  %s", label);
    for (const char *p = section; (p = strstr(p, row)); p++) {
        const char c = p[strlen(row)];
        if (c == ' ' || c == '\n')
            return 1;
    }
    return 0;
}

static void check_help_rows(const struct esr_command *cmd, int *checked)
{
    char args[64];
    snprintf(args, sizeof args, "%s --help", cmd->name);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("esr %s failed:\n%s", args, out);
    const char *section = options_section(out);
    if (!section)
        fail_msg("`esr %s` has no options section:\n%s", args, out);
    int n = 0;
    for (const struct cli_option *o = cmd->options; o->name; o++, n++) {
        if (!is_option(o))
            continue;
        char label[128];
        snprintf(label, sizeof label, "%s%s%s", o->name, o->arg ? " " : "", o->arg ? o->arg : "");
        if (!has_row(section - 1, label))
            fail_msg("esr %s: the table's %s has no row '%s' in --help:\n%s", cmd->name, o->name,
                     label, section);
        /* a value's own refusal names the option */
        if (o->bad && strncmp(o->bad, o->name, strlen(o->name)) && o->kind != CLI_ARGS)
            fail_msg("esr %s %s: its message '%s' does not start with its name", cmd->name,
                     o->name, o->bad);
        assert_true(o->help && o->help[0]);
        ++*checked;
    }
    assert_true(n < CLI_OPTIONS_MAX);
    /* and every row is the table's */
    for (const char *p = section - 1; (p = strstr(p, "\n  --")); p++) {
        char name[64];
        const size_t len = strcspn(p + 3, " \n");
        snprintf(name, sizeof name, "%.*s", (int)(len < 60 ? len : 60), p + 3);
        if (!cli_option_find(cmd->options, name) && strcmp(name, "--help"))
            fail_msg("esr %s --help lists %s, which its table does not have", cmd->name, name);
    }
    assert_true(has_row(section - 1, "-h, --help"));
}

static void test_every_table_option_is_in_help(void **state)
{
    (void)state;
    int commands = 0, checked = 0;
    for (int i = 0; cli_commands[i]; i++, commands++)
        check_help_rows(cli_commands[i], &checked);
    print_message("%d commands, %d options, each a row of its --help\n", commands, checked);
    assert_true(commands >= 12);
    assert_true(checked >= 60);
}

/* `esr CMD ARGS` exits 1 saying `want`. */
static void expect_refused(const struct esr_command *cmd, const char *args, const char *want)
{
    char line[512];
    snprintf(line, sizeof line, "%s %s", cmd->name, args);
    const int rc = test_run_esr(line, out, sizeof out);
    if (rc != 1 || !strstr(out, want))
        fail_msg("esr %s: exit %d, expected 1 and '%s' in:\n%s", line, rc, want, out);
}

/* Each option as its table says: refused only for what it lacks, never as unknown. Nothing
 * runs: every line is refused while it is parsed. */
static void test_parsing_takes_the_tables_options(void **state)
{
    (void)state;
    int checked = 0;
    for (int i = 0; cli_commands[i]; i++) {
        const struct esr_command *cmd = cli_commands[i];
        for (const struct cli_option *o = cmd->options; o->name; o++) {
            if (!is_option(o))
                continue;
            char args[256], want[256];
            if (o->arg) {
                snprintf(args, sizeof args, "%s", o->name);
                snprintf(want, sizeof want, "%s needs a value (%s %s)", o->name, o->name, o->arg);
            } else {
                snprintf(args, sizeof args, "%s=1", o->name);
                snprintf(want, sizeof want, "%s takes no value (got '%s=1')", o->name, o->name);
            }
            expect_refused(cmd, args, want);
            /* a near miss: the nearest option named */
            snprintf(args, sizeof args, "%sz", o->name);
            snprintf(want, sizeof want, "unknown option '%sz' (did you mean %s?)", o->name, o->name);
            expect_refused(cmd, args, want);
            checked++;
        }
        expect_refused(cmd, "--zzzzzzzzzz", "unknown option '--zzzzzzzzzz'\n");
    }
    print_message("%d options parsed as their tables say\n", checked);
}

/* The parse is the table's: no cmd_*.c reads an argv[] against an option name with strcmp. */
static void test_no_command_parses_by_hand(void **state)
{
    (void)state;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/cli", ESR_SOURCE_DIR);
    DIR *d = opendir(dir);
    assert_non_null(d);
    int files = 0;
    for (struct dirent *e; (e = readdir(d));) {
        const size_t len = strlen(e->d_name);
        if (strncmp(e->d_name, "cmd_", 4) || len < 7 || strcmp(e->d_name + len - 2, ".c"))
            continue;
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        unsigned char *src;
        size_t size;
        assert_int_equal(esr_file_read_all(path, &src, &size), 0);
        for (const char *p = strstr((char *)src, "strcmp("); p; p = strstr(p + 1, "strcmp(")) {
            const char *close = strchr(p, ')'), *q = strstr(p, "argv["), *dash = strstr(p, "\"-");
            if (close && q && dash && q < close && dash < close)
                fail_msg("%s compares an argument with an option itself: %.60s", e->d_name, p);
        }
        free(src);
        files++;
    }
    closedir(d);
    assert_true(files >= 12);
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
    assert_int_equal(test_run_esr("export RUN --no-color=1", out, sizeof out), 1);
    assert_non_null(strstr(out, "--no-colour takes no value"));
    assert_int_equal(test_run_esr("train DATA --out R --resme", out, sizeof out), 1);
    assert_non_null(strstr(out, "did you mean --resume?"));
    /* a typo in a value's place is told as a typo */
    assert_int_equal(test_run_esr("render RUN --frames --limt 2", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown option '--limt' (did you mean --limit?)"));
    assert_int_equal(test_run_esr("trian DATA", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown command 'trian' (did you mean train?)"));
    assert_int_equal(test_run_esr("frobnicate", out, sizeof out), 1);
    assert_null(strstr(out, "did you mean"));
    assert_int_equal(test_run_esr("help nosuch", out, sizeof out), 1);
    assert_int_equal(test_run_esr("help edit", out, sizeof out), 0);
    assert_non_null(strstr(out, "usage: esr edit"));
    /* an unknown option is refused even beside --help */
    assert_int_equal(test_run_esr("edit --help --wat", out, sizeof out), 1);
    assert_non_null(strstr(out, "unknown option '--wat'"));
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
        cmocka_unit_test(test_every_table_option_is_in_help),
        cmocka_unit_test(test_parsing_takes_the_tables_options),
        cmocka_unit_test(test_no_command_parses_by_hand),
        cmocka_unit_test(test_grammar),
        cmocka_unit_test(test_suggest),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
