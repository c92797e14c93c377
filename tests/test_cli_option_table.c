/* The option-table parser and help (src/cli/option_table.h) on a table of every kind: values in
 * and out of range, a missing value, --name=value, a flag given a value, repeated options (the
 * last counts, or refused when once), repeatable ones, both spellings of colour, handlers,
 * positional arguments, unknown options with the nearest one, and the help's aligned rows. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"

struct args {
    const char *run, *text, *once_text;
    int n, flag, calls, odd;
    double x;
    struct cli_texts sets;
    const char *called_with;
};

static int count_call(void *args, const struct cli_option *o, const char *value)
{
    struct args *a = args;
    (void)o;
    a->calls++;
    a->called_with = value;
    return 0;
}

static const struct esr_command cmd_test;

/* --odd N: its own kind of value (an odd number), refused here */
static int odd_value(void *args, const struct cli_option *o, const char *value)
{
    struct args *a = args;
    if (cli_parse_int(value, 1, 99, &a->odd) || a->odd % 2 == 0)
        return cli_fail(&cmd_test, "%s: expected an odd number, got '%s'", o->name, value);
    return 0;
}

#define AT(field) offsetof(struct args, field)
static const struct cli_option options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--n", "N", "a count", CLI_INT, .at = AT(n), .lo = 1, .hi = 10},
    {"--x", "X", "a fraction", CLI_DOUBLE, .at = AT(x), .lo = 0, .hi = 1},
    {"--flag", NULL, "a switch", CLI_FLAG, .at = AT(flag), .call = count_call},
    {"--text", "T", "a word", CLI_TEXT, .at = AT(text)},
    {"--once", "T", "a word given once", CLI_TEXT, .at = AT(once_text), .once = 1},
    {"--set", "key=value", "repeatable", CLI_TEXTS, .at = AT(sets), .hi = 2},
    {"--odd", "N", "an odd number", CLI_CALL, .call = odd_value},
    {"--bounded", "B", "with its own message", CLI_INT, .at = AT(n), .lo = 1, .hi = 3,
     .bad = "--bounded: expected 1..3, got '%s'"},
    {"--no-colour", NULL, "the British spelling in the table", CLI_FLAG, .at = AT(flag)},
    {"--a-very-long-option-name", "VALUE", "a long text that is wrapped: one two three four five six "
     "seven eight nine ten eleven twelve thirteen fourteen fifteen sixteen seventeen eighteen "
     "nineteen twenty", CLI_TEXT, .at = AT(text)},
    {0},
};

static const struct esr_command cmd_test = {
    .name = "test",
    .summary = "a command of every kind of option",
    .usage = "usage: esr test RUN [options]\n",
    .options = options,
};

static char said[1 << 14];

/* Parses the words of line (split at spaces) into *a, fresh; what was printed (stdout and
 * stderr) goes to `said`. Returns cli_parse's result. */
static int parse(const char *line, struct args *a)
{
    static char copy[1024];
    char *argv[32] = {"test"};
    int argc = 1;
    snprintf(copy, sizeof copy, "%s", line);
    for (char *w = strtok(copy, " "); w && argc < 31; w = strtok(NULL, " "))
        argv[argc++] = w;
    memset(a, 0, sizeof *a);
    fflush(stdout);
    fflush(stderr);
    FILE *tmp = tmpfile();
    assert_non_null(tmp);
    const int out = dup(1), err = dup(2);
    dup2(fileno(tmp), 1);
    dup2(fileno(tmp), 2);
    const int rc = cli_parse(&cmd_test, argc, argv, a);
    fflush(stdout);
    fflush(stderr);
    dup2(out, 1);
    dup2(err, 2);
    close(out);
    close(err);
    rewind(tmp);
    const size_t n = fread(said, 1, sizeof said - 1, tmp);
    said[n] = '\0';
    fclose(tmp);
    return rc;
}

static void test_values(void **state)
{
    (void)state;
    struct args a;
    assert_int_equal(parse("run --n 4 --x 0.25 --flag --text hi --set a=1 --set b=2", &a),
                     CLI_PARSED);
    assert_string_equal(a.run, "run");
    assert_int_equal(a.n, 4);
    assert_true(a.x == 0.25);
    assert_int_equal(a.flag, 1);
    assert_int_equal(a.calls, 1); /* a flag's handler, with no value */
    assert_null(a.called_with);
    assert_string_equal(a.text, "hi");
    assert_int_equal(a.sets.n, 2);
    assert_string_equal(a.sets.v[0], "a=1");
    assert_string_equal(a.sets.v[1], "b=2");
    assert_string_equal(said, "");
    /* nothing given: nothing stored */
    assert_int_equal(parse("", &a), CLI_PARSED);
    assert_null(a.run);
    assert_int_equal(a.n + a.flag + a.sets.n, 0);
    /* --name=value, the value with '=' of its own */
    assert_int_equal(parse("--n=7 --x=1 --text=k=v --set=c=3", &a), CLI_PARSED);
    assert_int_equal(a.n, 7);
    assert_true(a.x == 1.0);
    assert_string_equal(a.text, "k=v");
    assert_string_equal(a.sets.v[0], "c=3");
    /* the value is the next argument whatever it is: "-1", "-" or another option's name */
    assert_int_equal(parse("--text -1 -", &a), CLI_PARSED);
    assert_string_equal(a.text, "-1");
    assert_string_equal(a.run, "-");
    assert_int_equal(parse("--text --flag", &a), CLI_PARSED);
    assert_string_equal(a.text, "--flag");
    assert_int_equal(a.flag, 0);
    /* a handler's own kind of value */
    assert_int_equal(parse("--odd 7", &a), CLI_PARSED);
    assert_int_equal(a.odd, 7);
}

/* line is refused saying want, as every command's errors say it: the command named, then
 * where to look. */
static void refused(const char *line, const char *want)
{
    struct args a;
    const int rc = parse(line, &a);
    if (rc != CLI_REFUSED || !strstr(said, want))
        fail_msg("'%s': result %d, expected refused with '%s', said:\n%s", line, rc, want, said);
    assert_non_null(strstr(said, "esr test: error: "));
    assert_non_null(strstr(said, "(see `esr test --help`)"));
}

/* Each refused, the message naming the option and what was wrong. */
static void test_refusals(void **state)
{
    (void)state;
    char longname[80];
    memset(longname, 'a', sizeof longname);
    memcpy(longname, "--", 2);
    longname[79] = '\0';
    /* a value out of range or malformed */
    refused("--n 0", "--n must be an integer in 1..10, got '0'");
    refused("--n 11", "--n must be an integer in 1..10, got '11'");
    refused("--n=2.5", "--n must be an integer in 1..10, got '2.5'");
    refused("--n 0x3", "--n must be an integer in 1..10, got '0x3'");
    refused("--n +3", "--n must be an integer in 1..10, got '+3'");
    refused("--x 1.5", "--x must be a number in 0..1, got '1.5'");
    refused("--x -0.1", "--x must be a number in 0..1, got '-0.1'");
    refused("--x nan", "--x must be a number in 0..1, got 'nan'");
    refused("--x=", "--x must be a number in 0..1, got ''");
    refused("--bounded 4", "--bounded: expected 1..3, got '4'");
    refused("--odd 8", "--odd: expected an odd number, got '8'");
    /* a value missing, or given to a flag */
    refused("run --n", "--n needs a value (--n N)");
    refused("--set", "--set needs a value (--set key=value)");
    refused("--flag=1", "--flag takes no value (got '--flag=1')");
    refused("--flag=", "--flag takes no value (got '--flag=')");
    /* given more often than it may be */
    refused("--once a --once b", "--once given twice");
    refused("--once=a --once b", "--once given twice");
    refused("--set a --set b --set c", "more than 2 --set options");
    refused("a b", "more than one RUN given ('a', 'b')");
    /* unknown, with the nearest option; anywhere (a value's place too), before any value
     * is read, beside --help too */
    refused("--nn 3", "unknown option '--nn' (did you mean --n?)");
    refused("--fleg", "unknown option '--fleg' (did you mean --flag?)");
    refused("--hlep", "unknown option '--hlep' (did you mean --help?)");
    refused("--wholly-unlike-anything", "unknown option '--wholly-unlike-anything'\n");
    refused("-q", "unknown option '-q'");
    refused("--n 0 --text --bogus", "unknown option '--bogus'");
    refused("--x=2 --nope=1", "unknown option '--nope'");
    refused("--n 3 --help --wat", "unknown option '--wat'");
    refused(longname, "unknown option '--aaaa");
}

static void test_repeated_and_spellings(void **state)
{
    (void)state;
    struct args a;
    assert_int_equal(parse("--text a --text b --n 2 --n 3", &a), CLI_PARSED);
    assert_string_equal(a.text, "b"); /* the last counts */
    assert_int_equal(a.n, 3);
    assert_int_equal(parse("--flag --flag", &a), CLI_PARSED);
    assert_int_equal(a.calls, 2);
    /* either spelling of colour takes the table's */
    assert_int_equal(parse("--no-color", &a), CLI_PARSED);
    assert_int_equal(a.flag, 1);
    assert_int_equal(parse("--no-colour", &a), CLI_PARSED);
    assert_int_equal(a.flag, 1);
    assert_non_null(cli_option_find(options, "--no-colour"));
    assert_ptr_equal(cli_option_find(options, "--no-color"), cli_option_find(options, "--no-colour"));
    assert_null(cli_option_find(options, "RUN")); /* a positional is no option */
}

static void test_help(void **state)
{
    (void)state;
    struct args a;
    assert_int_equal(parse("--n 99 -h", &a), CLI_HELPED); /* before any value is checked */
    assert_int_equal(a.n, 0);
    assert_non_null(strstr(said, "usage: esr test RUN [options]\n\noptions:\n"));
    /* aligned rows: the widest label up to 22 columns sets the column; a longer label stands
     * on its own line */
    static const char *const rows[] = {
        "\n  --n N            a count\n",
        "\n  --set key=value  repeatable\n",
        "\n  --flag           a switch\n",
        "\n  --a-very-long-option-name VALUE\n                   a long",
        "\n  -h, --help       this text\n",
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++)
        if (!strstr(said, rows[i]))
            fail_msg("no row '%s' in:\n%s", rows[i], said);
    assert_null(strstr(said, "RUN  ")); /* positionals have no row */
    for (const char *line = said; *line;) {
        const size_t len = strcspn(line, "\n");
        if (len > 96)
            fail_msg("a help line of %zu columns: %.*s", len, (int)len, line);
        line += len + (line[len] == '\n');
    }
    assert_int_equal(parse("--help", &a), CLI_HELPED);
    assert_int_equal(parse("x --help=1", &a), CLI_HELPED);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_values),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_repeated_and_spellings),
        cmocka_unit_test(test_help),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
