/* Ctrl-C and SIGTERM for the commands that write results (edit, eval, export): the results
 * they replace stay as they were. A command writes its new files aside (under temporary names
 * registered here, or in a staging folder) and moves them into place only when all are
 * complete. The first signal either sets a flag the command checks between units of work
 * (cli_interrupted) or, for a command that has no such points, removes the registered
 * temporary files and exits at once; a second signal ends the process at once. What a kill -9
 * leaves carries the dead process's id in its name and is removed by the next command that
 * writes there (io/stale.h). */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "core/error.h"

#define MAX_ASIDE 16

static volatile sig_atomic_t flag;
static int exit_at_once;
static const char *who;
static char aside[MAX_ASIDE][4200];
static volatile sig_atomic_t n_aside;

static void say(const char *text)
{
    (void)!write(2, text, strlen(text));
}

static void on_signal(int sig)
{
    const int saved = errno;
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    signal(SIGPIPE, SIG_IGN); /* `esr edit | tee`: tee is gone with the Ctrl-C */
    flag = sig;
    if (exit_at_once) {
        for (int i = 0; i < n_aside; i++)
            unlink(aside[i]);
        say("\nesr ");
        say(who);
        say(": interrupted: nothing was replaced (the earlier results are as they were)\n");
        _exit(128 + sig);
    }
    say("\nesr ");
    say(who);
    say(": stopping after this step (again to stop at once); nothing will be replaced\n");
    errno = saved;
}

void cli_catch_interrupt(const struct esr_command *cmd, int at_once)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    who = cmd->name;
    exit_at_once = at_once;
    flag = 0;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

int cli_interrupted(void)
{
    return flag;
}

const char *cli_aside_register(const char *path)
{
    if (n_aside >= MAX_ASIDE || strlen(path) >= sizeof aside[0])
        return NULL;
    memcpy(aside[n_aside], path, strlen(path) + 1);
    n_aside++;
    return aside[n_aside - 1];
}

void cli_aside_clear(void)
{
    n_aside = 0;
}

int cli_hold_signals(int hold)
{
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    return sigprocmask(hold ? SIG_BLOCK : SIG_UNBLOCK, &set, NULL);
}

const char *cli_aside_add(struct cli_aside *s, const char *final)
{
    const size_t len = strlen(final);
    if (s->n >= CLI_ASIDE_MAX || len >= sizeof s->final[0])
        return NULL;
    memcpy(s->final[s->n], final, len + 1);
    /* "<file>.tmp-<pid>-staged": the name io/stale.h sweeps when this process is gone */
    snprintf(s->temp[s->n], sizeof s->temp[0], "%s.tmp-%ld-staged", final, (long)getpid());
    unlink(s->temp[s->n]); /* a reused pid's leftover */
    const char *t = cli_aside_register(s->temp[s->n]);
    s->n++;
    return t ? t : s->temp[s->n - 1];
}

int cli_aside_commit(struct cli_aside *s)
{
    int rc = ESR_OK;
    cli_hold_signals(1);
    for (int i = 0; i < s->n; i++)
        if (access(s->temp[i], F_OK) == 0 && rename(s->temp[i], s->final[i]) != 0 && rc == ESR_OK)
            rc = ESR_FAIL("cannot move %s to %s: %s", s->temp[i], s->final[i], strerror(errno));
    cli_aside_clear();
    cli_hold_signals(0);
    if (rc != ESR_OK)
        cli_aside_discard(s);
    s->n = 0;
    return rc;
}

void cli_aside_discard(struct cli_aside *s)
{
    for (int i = 0; i < s->n; i++)
        unlink(s->temp[i]);
    cli_aside_clear();
    s->n = 0;
}
