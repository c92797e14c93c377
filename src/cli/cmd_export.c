/* esr export RUN --mesh out.ply | --gltf out.glb: the model's surface as a coloured PLY mesh or a
 * relightable glTF asset. */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "core/error.h"
#include "io/ply.h"
#include "io/staging.h"
#include "render/model_gltf.h"
#include "render/model_mesh.h"
#include "model/model.h"

static int run_export(int argc, char **argv);

const struct esr_command cmd_export = {
    "export",
    "extract the model's surface (marching cubes on the SDF) as a PLY mesh or a relightable glTF",
    "usage: esr export RUN [--mesh OUT.ply] [--gltf OUT.glb] [options]  (at least one of the two)\n"
    "\n"
    "Loads the most advanced checkpoint in run directory RUN (or RUN may be a checkpoint file),\n"
    "extracts the zero level set of its SDF grid by marching cubes and writes a binary PLY with\n"
    "vertex normals (pointing out of the surface) and vertex colours: the model's linear radiance\n"
    "with the lights off, seen along the normal, clipped to [0,1].\n"
    "\n"
    "With --gltf, a relightable binary glTF (render/model_gltf.h): the same surface with the\n"
    "reconstructed base colour per vertex, roughness and metallic, and each light found as its\n"
    "own node (light_<id>) emitting its calibrated radiance (KHR_materials_emissive_strength).\n"
    "\n"
    "options:\n"
    "  --mesh FILE   output PLY\n"
    "  --gltf FILE   output GLB (one of --mesh, --gltf is needed; both write two files, not one\n"
    "                file for both, and when the glTF fails the PLY is removed again)\n"
    "  --res N       resample the SDF to N^3 lattice points first (8..1024; default: the model's grid)\n"
    "  --no-colour   PLY: leave out vertex colours (faster)\n"
    "  -h, --help    this text\n",
    run_export,
    0, /* view_loop */
};

static int export_mesh(const char *run, const char *mesh_path, const char *gltf_path, int res,
                       int colours)
{
    struct esr_model model;
    struct esr_mesh mesh;
    memset(&mesh, 0, sizeof mesh);
    ESR_TRY(esr_model_load(&model, run));
    int status = ESR_OK;
    if (mesh_path) {
        status = esr_model_mesh(&model, res, colours, &mesh);
        if (status == ESR_OK)
            status = esr_ply_write(mesh_path, &mesh);
        if (status == ESR_OK)
            fprintf(stderr, "wrote %s: %zu vertices, %zu triangles (%s model, step %ld)\n", mesh_path,
                    mesh.n_vertices, mesh.n_triangles, esr_stage_name((enum esr_stage)model.stage),
                    model.step);
    }
    if (status == ESR_OK && gltf_path) {
        status = esr_model_gltf_write(&model, res, gltf_path);
        if (status == ESR_OK)
            fprintf(stderr, "wrote %s: the surface and %d light node(s) (%s model)\n", gltf_path,
                    model.lights.n, esr_stage_name((enum esr_stage)model.stage));
        else if (mesh_path && unlink(mesh_path) == 0) /* both or neither */
            fprintf(stderr, "removed %s again: the glTF could not be written\n", mesh_path);
    }
    esr_mesh_free(&mesh);
    esr_model_free(&model);
    return status;
}

static int run_export(int argc, char **argv)
{
    if (cli_wants_help(&cmd_export, argc, argv))
        return 0;
    const char *run = NULL, *mesh = NULL, *gltf = NULL;
    int res = 0, colours = 1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int has_value = i + 1 < argc;
        if (!strcmp(a, "--mesh") && has_value)
            mesh = argv[++i];
        else if (!strcmp(a, "--gltf") && has_value)
            gltf = argv[++i];
        else if (!strcmp(a, "--no-colour"))
            colours = 0;
        else if (!strcmp(a, "--res") && has_value) {
            if (cli_parse_int(argv[++i], ESR_MODEL_MESH_RES_MIN, ESR_MODEL_MESH_RES_MAX, &res))
                return cli_fail(&cmd_export, "--res must be an integer in %d..%d, got '%s'", ESR_MODEL_MESH_RES_MIN,
                                ESR_MODEL_MESH_RES_MAX, argv[i]);
        } else if (a[0] == '-' && a[1])
            return cli_fail(&cmd_export, "unknown option or missing value: '%s'", a);
        else if (run)
            return cli_fail(&cmd_export, "more than one RUN given ('%s', '%s')", run, a);
        else
            run = a;
    }
    if (!run)
        return cli_fail(&cmd_export, "missing RUN directory");
    if (!mesh && !gltf)
        return cli_fail(&cmd_export, "missing --mesh OUT.ply or --gltf OUT.glb");
    if (mesh && gltf) { /* the glTF would replace the PLY just written */
        char a[4096], b[4096];
        if (esr_path_resolve(mesh, a, sizeof a) != ESR_OK || esr_path_resolve(gltf, b, sizeof b) != ESR_OK)
            return cli_fail_lib(&cmd_export);
        if (!strcmp(a, b))
            return cli_fail(&cmd_export, "--mesh and --gltf name the same file (%s)", a);
    }
    return export_mesh(run, mesh, gltf, res, colours) == ESR_OK ? 0 : cli_fail_lib(&cmd_export);
}
