/* One option grammar for every command: `--name value` and `--name=value`, British and American
 * spellings of colour alike, and an unknown option answered with the nearest one the command
 * has. The options a command has are the ones its usage text names, so what --help shows and
 * what is accepted cannot drift apart (tests/test_cli_options.c checks every command). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/suggest.h"

#define MAX_NAMES 160
#define MAX_NAME 48

struct names {
    char v[MAX_NAMES][MAX_NAME];
    const char *p[MAX_NAMES];
    int n;
};

/* Every "--word" in the usage text (word: lowercase letters, digits and '-'). */
static void usage_options(const char *usage, struct names *out)
{
    out->n = 0;
    for (const char *c = usage; (c = strstr(c, "--"));) {
        const char *w = c + 2;
        size_t len = strspn(w, "abcdefghijklmnopqrstuvwxyz0123456789-");
        const int starts = c == usage || !strchr("abcdefghijklmnopqrstuvwxyz0123456789-", c[-1]);
        if (starts && len >= 1 && w[0] != '-' && len + 3 < MAX_NAME) {
            char name[MAX_NAME];
            snprintf(name, sizeof name, "--%.*s", (int)len, w);
            int seen = 0;
            for (int i = 0; i < out->n && !seen; i++)
                seen = !strcmp(out->v[i], name);
            if (!seen && out->n < MAX_NAMES) {
                memcpy(out->v[out->n], name, strlen(name) + 1);
                out->p[out->n] = out->v[out->n];
                out->n++;
            }
        }
        c = w + len;
    }
}

static int known(const struct names *k, const char *name)
{
    for (int i = 0; i < k->n; i++)
        if (!strcmp(k->p[i], name))
            return 1;
    return 0;
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

static char **volatile normalised; /* kept for the process: the command's argv (volatile: a
                                     store never read back would be dropped, and LeakSanitizer
                                     would then call the argv a leak) */
static int typed_argc;    /* and what was typed, for the records of what made an output */
static char **typed_argv;

int cli_typed_args(char ***argv)
{
    *argv = typed_argv;
    return typed_argc;
}

int cli_normalise_args(const struct esr_command *cmd, int *argc, char ***argv)
{
    struct names k;
    usage_options(cmd->usage, &k);
    const int n = *argc;
    char **in = *argv;
    typed_argc = n;
    typed_argv = in;
    char **out = calloc((size_t)(2 * n + 1), sizeof *out);
    if (!out) {
        fprintf(stderr, "esr %s: error: out of memory\n", cmd->name);
        return 1;
    }
    int m = 0;
    for (int i = 0; i < n; i++) {
        const char *a = in[i];
        if (i == 0 || strncmp(a, "--", 2) != 0 || !a[2]) {
            out[m++] = in[i];
            continue;
        }
        char name[MAX_NAME + 8];
        const char *eq = strchr(a, '=');
        const size_t len = eq ? (size_t)(eq - a) : strlen(a);
        if (len >= MAX_NAME) {
            fprintf(stderr, "esr %s: error: unknown option '%s'\n(see `esr %s --help`)\n",
                    cmd->name, a, cmd->name);
            free(out);
            return 1;
        }
        memcpy(name, a, len);
        name[len] = '\0';
        char alias[MAX_NAME + 8];
        const char *use = name;
        if (!known(&k, name) && other_spelling(name, alias, sizeof alias) && known(&k, alias))
            use = alias;
        if (!known(&k, use)) {
            const char *near = esr_suggest(name, k.p, k.n);
            fprintf(stderr, "esr %s: error: unknown option '%s'%s%s%s\n(see `esr %s --help`)\n",
                    cmd->name, name, near ? " (did you mean " : "", near ? near : "",
                    near ? "?)" : "", cmd->name);
            free(out);
            return 1;
        }
        if (use == name && !eq) {
            out[m++] = in[i];
            continue;
        }
        out[m++] = strdup(use);
        if (eq)
            out[m++] = strdup(eq + 1);
        if (!out[m - 1]) {
            fprintf(stderr, "esr %s: error: out of memory\n", cmd->name);
            return 1;
        }
    }
    out[m] = NULL;
    normalised = out;
    *argc = m;
    *argv = normalised;
    return 0;
}
