/* esr export RUN --mesh out.ply | --gltf out.glb: the model's surface as a coloured PLY mesh or a
 * relightable glTF asset. */
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "io/dir.h"
#include "core/error.h"
#include "io/ply.h"
#include "io/stale.h"
#include "io/staging.h"
#include "render/model_gltf.h"
#include "render/model_mesh.h"
#include "model/model.h"

static int run_export(int argc, char **argv);

struct export_args {
    const char *run, *mesh, *gltf;
    int res, no_colour, materials;
};

#define AT(field) offsetof(struct export_args, field)
static const struct cli_option export_options[] = {
    {"RUN", .kind = CLI_ARG, .at = AT(run)},
    {"--mesh", "FILE", "output PLY", CLI_TEXT, .at = AT(mesh)},
    {"--gltf", "FILE", "output GLB (one of --mesh, --gltf is needed; both write two files, not one "
     "file for both, both or neither: when the glTF fails an earlier PLY stays)", CLI_TEXT,
     .at = AT(gltf)},
    {"--res", "N", "resample the SDF to N^3 lattice points first (8..1024; default: the model's "
     "grid)", CLI_INT, .at = AT(res), .lo = ESR_MODEL_MESH_RES_MIN, .hi = ESR_MODEL_MESH_RES_MAX},
    {"--materials", "N", "glTF: split the surface into at most N materials (1..16; default 8) by "
     "clustering its triangles' roughness and metallic, centres at least 0.1 apart, each at "
     "least 1% of the area (1: one material, the surface's mean)", CLI_INT, .at = AT(materials),
     .lo = 1, .hi = ESR_GLTF_MAX_MATERIALS},
    {"--no-colour", NULL, "PLY: leave out vertex colours (faster)", CLI_FLAG, .at = AT(no_colour)},
    {0},
};

const struct esr_command cmd_export = {
    .name = "export",
    .summary = "extract the model's surface (marching cubes on the SDF) as a PLY mesh or a "
               "relightable glTF",
    .usage =
    "usage: esr export RUN [--mesh OUT.ply] [--gltf OUT.glb] [options]  (at least one of the two)\n"
    "\n"
    "Loads the most advanced checkpoint in run directory RUN (or RUN may be a checkpoint file),\n"
    "extracts the zero level set of its SDF grid by marching cubes and writes a binary PLY with\n"
    "vertex normals (pointing out of the surface) and vertex colours: the model's linear radiance\n"
    "with the lights off, seen along the normal, clipped to [0,1].\n"
    "\n"
    "With --gltf, a relightable binary glTF (render/model_gltf.h): the same surface with the\n"
    "reconstructed base colour per vertex, split into a few materials (surface_<n>) by the\n"
    "roughness and metallic of its triangles (--materials), and each light found as its own node\n"
    "(light_<id>) emitting its calibrated radiance (KHR_materials_emissive_strength).\n",
    .options = export_options,
    .run = run_export,
};

/* The glTF of model to gltf_path, saying which lights got their node and the materials. */
static int export_gltf(const struct esr_model *model, const struct esr_gltf_options *o,
                       const char *gltf_path)
{
    struct esr_gltf_summary sum;
    ESR_TRY(esr_model_gltf_write(model, o, gltf_path, &sum));
    int written = 0;
    for (int k = 0; k < model->lights.n; k++) {
        written += (sum.light_nodes >> k) & 1;
        if (!((sum.light_nodes >> k) & 1))
            fprintf(stderr, "esr export: warning: light %d has no triangle at this resolution, so "
                            "no node (a larger --res gives it one)\n", k);
    }
    fprintf(stderr, "wrote %s: the surface and %d light node(s) (%s model)\n", gltf_path, written,
            esr_stage_name((enum esr_stage)model->stage));
    fprintf(stderr, "  the surface's %d material(s), roughness / metallic (share of the area):",
            sum.n_materials);
    for (int j = 0; j < sum.n_materials; j++)
        fprintf(stderr, "%s %.2f / %.2f (%.0f%%)", j ? "," : "", (double)sum.roughness[j],
                (double)sum.metallic[j], 100.0 * (double)sum.share[j]);
    fprintf(stderr, "\n");
    return ESR_OK;
}

/* Both files or neither: the PLY goes to a temporary name beside mesh_path and takes its name
 * only once the glTF is written, so a failed glTF leaves an earlier mesh_path as it was. */
static int export_mesh(const char *run, const char *mesh_path, const char *gltf_path,
                       const struct esr_gltf_options *o, int colours)
{
    struct esr_model model;
    struct esr_mesh mesh;
    memset(&mesh, 0, sizeof mesh);
    ESR_TRY(esr_model_load(&model, run));
    int status = ESR_OK;
    char tmp[4200] = "";
    if (mesh_path) {
        char prefix[4150];
        snprintf(prefix, sizeof prefix, "%s.tmp-", mesh_path);
        status = esr_model_mesh(&model, o->res, colours, &mesh);
        if (status == ESR_OK && gltf_path) { /* the temporary name, reserved */
            status = esr_stale_template(tmp, sizeof tmp, prefix);
            const int fd = status == ESR_OK ? mkstemp(tmp) : -1;
            if (fd >= 0) {
                close(fd);
                cli_aside_register(tmp); /* removed by a Ctrl-C */
            }
            else {
                if (status == ESR_OK)
                    status = ESR_FAIL("cannot write beside %s: %s", mesh_path, strerror(errno));
                tmp[0] = '\0';
            }
        }
        if (status == ESR_OK)
            status = esr_ply_write(gltf_path ? tmp : mesh_path, &mesh);
    }
    if (status == ESR_OK && gltf_path)
        status = export_gltf(&model, o, gltf_path);
    if (status == ESR_OK && mesh_path && gltf_path && rename(tmp, mesh_path) != 0)
        status = ESR_FAIL("cannot rename %s to %s: %s", tmp, mesh_path, strerror(errno));
    if (status != ESR_OK && tmp[0])
        unlink(tmp);
    if (status == ESR_OK && mesh_path)
        fprintf(stderr, "wrote %s: %zu vertices, %zu triangles (%s model, step %ld)\n", mesh_path,
                mesh.n_vertices, mesh.n_triangles, esr_stage_name((enum esr_stage)model.stage),
                model.step);
    esr_mesh_free(&mesh);
    esr_model_free(&model);
    return status;
}

/* Refuses an output that would overwrite what the run is read from: the checkpoint RUN names, or
 * a run folder's checkpoints and records. */
static int check_not_input(const char *run, const char *out)
{
    char r[4096], o[4096];
    ESR_TRY(esr_path_resolve(run, r, sizeof r));
    ESR_TRY(esr_path_resolve(out, o, sizeof o));
    if (!strcmp(r, o))
        return ESR_FAIL("the output %s is the checkpoint it would be read from", out);
    const size_t n = strlen(r);
    const char *base = o + n + 1;
    if (strncmp(o, r, n) || o[n] != '/' || strchr(base, '/'))
        return ESR_OK; /* not directly inside the run folder */
    if ((!strncmp(base, "ckpt_", 5) && strstr(base, ".bin")) || !strcmp(base, "config.json") ||
        !strcmp(base, "run.json"))
        return ESR_FAIL("the output %s would replace the run's own %s", out, base);
    return ESR_OK;
}

static int run_export(int argc, char **argv)
{
    struct export_args args = {.materials = 8};
    const int parsed = cli_parse(&cmd_export, argc, argv, &args);
    if (parsed != CLI_PARSED)
        return parsed == CLI_HELPED ? 0 : 1;
    const char *run = args.run, *mesh = args.mesh, *gltf = args.gltf;
    const struct esr_gltf_options gltf_opts = {.res = args.res, .max_materials = args.materials};
    const int colours = !args.no_colour;
    if (!run)
        return cli_fail(&cmd_export, "missing RUN directory");
    if (!mesh && !gltf)
        return cli_fail(&cmd_export, "missing --mesh OUT.ply or --gltf OUT.glb");
    const char *outs[2] = {mesh, gltf};
    for (int i = 0; i < 2; i++)
        if (outs[i] && check_not_input(run, outs[i]) != ESR_OK)
            return cli_fail_lib(&cmd_export);
    if (esr_dir_check_run(run) != ESR_OK)
        return cli_fail_lib(&cmd_export);
    if (mesh && gltf) { /* the glTF would replace the PLY just written */
        char a[4096], b[4096];
        if (esr_path_resolve(mesh, a, sizeof a) != ESR_OK || esr_path_resolve(gltf, b, sizeof b) != ESR_OK)
            return cli_fail_lib(&cmd_export);
        if (!strcmp(a, b))
            return cli_fail(&cmd_export, "--mesh and --gltf name the same file (%s)", a);
    }
    /* the outputs' folders before the model is loaded and meshed */
    char made[2][4200] = {"", ""};
    int status = ESR_OK;
    if (mesh)
        status = cli_output_file("--mesh", mesh, ".ply", made[0], sizeof made[0]);
    if (status == ESR_OK && gltf)
        status = cli_output_file("--gltf", gltf, ".glb", made[1], sizeof made[1]);
    cli_catch_interrupt(&cmd_export, 1); /* the outputs are written atomically: a Ctrl-C keeps
                                            the earlier ones */
    if (status == ESR_OK)
        status = export_mesh(run, mesh, gltf, &gltf_opts, colours);
    if (status == ESR_OK)
        return 0;
    for (int i = 1; i >= 0; i--)
        if (outs[i])
            esr_dir_remove_made(outs[i], made[i]);
    return cli_fail_lib(&cmd_export);
}
