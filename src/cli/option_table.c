/* The parse of a command's arguments by its option table (option_table.h): one grammar for every
 * command, and only the table's options, so that --help (made from the same table) and what is
 * accepted cannot drift apart. */
#include "cli/option_table.h"

#include <string.h>

#include "cli/commands.h"
#include "core/suggest.h"

#define NAME_MAX_LEN 48 /* a longer "--word" names no option */

static int is_option(const char *a)
{
    return a[0] == '-' && a[1] == '-' && a[2];
}

/* The name part of "--name" or "--name=value" into out; 0 when it is too long to be an option. */
static int name_of(const char *a, char out[NAME_MAX_LEN])
{
    const size_t len = strcspn(a, "=");
    if (len >= NAME_MAX_LEN)
        return 0;
    memcpy(out, a, len);
    out[len] = '\0';
    return 1;
}

/* The other spelling of name when it has "colour" or "color" in it (into out), else 0. */
static int other_spelling(const char *name, char *out, size_t n)
{
    const char *uk = strstr(name, "colour"), *us = strstr(name, "color");
    if (uk)
        snprintf(out, n, "%.*scolor%s", (int)(uk - name), name, uk + 6);
    else if (us)
        snprintf(out, n, "%.*scolour%s", (int)(us - name), name, us + 5);
    return uk || us;
}

static const struct cli_option *find_exact(const struct cli_option *t, const char *name)
{
    for (; t->name; t++)
        if (t->name[0] == '-' && !strcmp(t->name, name))
            return t;
    return NULL;
}

const struct cli_option *cli_option_find(const struct cli_option *table, const char *name)
{
    char alias[NAME_MAX_LEN + 8];
    const struct cli_option *o = find_exact(table, name);
    if (!o && other_spelling(name, alias, sizeof alias))
        o = find_exact(table, alias);
    return o;
}

static int is_help(const char *a)
{
    return !strcmp(a, "-h") || !strcmp(a, "--help") || !strncmp(a, "--help=", 7);
}

/* An option the table does not have, answered with the nearest one it does. */
static int unknown(const struct esr_command *cmd, const char *name)
{
    const char *names[CLI_OPTIONS_MAX + 1];
    int n = 0;
    for (const struct cli_option *o = cmd->options; o->name && n < CLI_OPTIONS_MAX; o++)
        if (o->name[0] == '-')
            names[n++] = o->name;
    names[n++] = "--help";
    const char *near = esr_suggest(name, names, n);
    return cli_fail(cmd, "unknown option '%s'%s%s%s", name, near ? " (did you mean " : "",
                    near ? near : "", near ? "?)" : "");
}

/* Every "--word" of argv names an option: checked before any value is read, so that a typo is
 * told as such and not as the odd value of the option before it. */
static int check_names(const struct esr_command *cmd, int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        char name[NAME_MAX_LEN];
        if (!is_option(argv[i]))
            continue;
        if (!name_of(argv[i], name))
            return unknown(cmd, argv[i]);
        if (strcmp(name, "--help") && !cli_option_find(cmd->options, name))
            return unknown(cmd, name);
    }
    return CLI_PARSED;
}

/* A value the option refuses: its own message, else one from its kind and range. */
static int refuse(const struct esr_command *cmd, const struct cli_option *o, const char *value)
{
    if (o->bad)
        return cli_fail(cmd, o->bad, value);
    if (o->kind == CLI_INT)
        return cli_fail(cmd, "%s must be an integer in %.0f..%.0f, got '%s'", o->name, o->lo, o->hi,
                        value);
    return cli_fail(cmd, "%s must be a number in %g..%g, got '%s'", o->name, o->lo, o->hi, value);
}

/* Appends v to t, which holds at most `most` (and CLI_TEXTS_MAX); -1 when it is full. */
static int append(struct cli_texts *t, double most, const char *v)
{
    if (t->n >= (int)most || t->n >= CLI_TEXTS_MAX)
        return -1;
    t->v[t->n++] = v;
    return 0;
}

/* Stores value (NULL for a flag) where o says. */
static int store(const struct esr_command *cmd, const struct cli_option *o, const char *value,
                 void *args)
{
    char *at = (char *)args + o->at;
    switch (o->kind) {
    case CLI_FLAG:
        *(int *)(void *)at = 1;
        return CLI_PARSED;
    case CLI_INT:
        if (cli_parse_int(value, (long)o->lo, (long)o->hi, (int *)(void *)at))
            return refuse(cmd, o, value);
        return CLI_PARSED;
    case CLI_DOUBLE:
        if (cli_parse_double(value, o->lo, o->hi, (double *)(void *)at))
            return refuse(cmd, o, value);
        return CLI_PARSED;
    case CLI_TEXT:
        *(const char **)(void *)at = value;
        return CLI_PARSED;
    case CLI_TEXTS: {
        struct cli_texts *t = (struct cli_texts *)(void *)at;
        if (append(t, o->hi, value))
            return cli_fail(cmd, "more than %d %s options", t->n, o->name);
        return CLI_PARSED;
    }
    default: /* CLI_CALL: the handler stores */
        return CLI_PARSED;
    }
}

/* A positional argument, into the table's CLI_ARG or CLI_ARGS entry. */
static int positional(const struct esr_command *cmd, const char *a, void *args)
{
    const struct cli_option *p = cmd->options;
    while (p->name && p->kind != CLI_ARG && p->kind != CLI_ARGS)
        p++;
    if (!p->name)
        return cli_fail(cmd, "unexpected argument '%s'", a);
    char *at = (char *)args + p->at;
    if (p->kind == CLI_ARG) {
        const char **slot = (const char **)(void *)at;
        if (*slot)
            return cli_fail(cmd, "more than one %s given ('%s', '%s')", p->name, *slot, a);
        *slot = a;
    } else {
        if (append((struct cli_texts *)(void *)at, p->hi, a))
            return p->bad ? cli_fail(cmd, p->bad, a) : cli_fail(cmd, "too many arguments ('%s')", a);
    }
    return p->call ? p->call(args, p, a) : CLI_PARSED;
}

/* One option at argv[*i], its value from "=value" or the next argument (whatever that is: the
 * value of --out may be "-"). */
static int option(const struct esr_command *cmd, int argc, char **argv, int *i, void *args,
                  int *given)
{
    const char *a = argv[*i], *eq = strchr(a, '=');
    char name[NAME_MAX_LEN];
    name_of(a, name); /* check_names found it */
    const struct cli_option *o = cli_option_find(cmd->options, name);
    const char *value = eq ? eq + 1 : NULL;
    if (!o->arg && value)
        return cli_fail(cmd, "%s takes no value (got '%s')", o->name, a);
    if (o->arg && !value) {
        if (*i + 1 >= argc)
            return cli_fail(cmd, "%s needs a value (%s %s)", o->name, o->name, o->arg);
        value = argv[++*i];
    }
    const int k = (int)(o - cmd->options); /* < CLI_OPTIONS_MAX (option_table.h) */
    if (o->once && given[k])
        return cli_fail(cmd, "%s given twice", o->name);
    given[k] = 1;
    if (store(cmd, o, value, args) != CLI_PARSED)
        return CLI_REFUSED;
    return o->call && o->call(args, o, value) ? CLI_REFUSED : CLI_PARSED;
}

int cli_parse(const struct esr_command *cmd, int argc, char **argv, void *args)
{
    if (check_names(cmd, argc, argv) != CLI_PARSED)
        return CLI_REFUSED;
    for (int i = 1; i < argc; i++)
        if (is_help(argv[i])) {
            cli_print_help(cmd, stdout);
            return CLI_HELPED;
        }
    int given[CLI_OPTIONS_MAX] = {0};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int rc;
        if (is_option(a))
            rc = option(cmd, argc, argv, &i, args, given);
        else if (a[0] == '-' && a[1]) /* no short options but -h */
            rc = unknown(cmd, a);
        else
            rc = positional(cmd, a, args);
        if (rc != CLI_PARSED)
            return CLI_REFUSED;
    }
    return CLI_PARSED;
}
