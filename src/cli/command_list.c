/* The subcommands, in the order `esr --help` lists them: main.c dispatches by it, and
 * tests/test_cli_options.c checks every command's option table by it. */
#include <stddef.h>

#include "cli/commands.h"

const struct esr_command *const cli_commands[] = {
    &cmd_demo,   &cmd_info,   &cmd_import, &cmd_metrics, &cmd_synth, &cmd_train, &cmd_render,
    &cmd_eval,   &cmd_export, &cmd_lights, &cmd_edit,    &cmd_lightmix, &cmd_bench, NULL,
};
