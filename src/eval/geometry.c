#include "eval/geometry.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "io/ply.h"
#include "render/model_mesh.h"
#include "io/json_file.h"

int esr_geometry_gt_path(const char *data_dir, char *out, size_t n)
{
    if (snprintf(out, n, "%s/gt/mesh.ply", data_dir) >= (int)n)
        return 0;
    return esr_file_exists(out);
}

int esr_geometry_score(const struct esr_model *m, const char *gt_path, struct esr_chamfer_result *out)
{
    struct esr_mesh gt, pred;
    memset(&gt, 0, sizeof gt);
    memset(&pred, 0, sizeof pred);
    int rc = esr_ply_read(gt_path, &gt);
    if (rc == ESR_OK)
        rc = esr_model_mesh(m, 0, 0, &pred);
    if (rc == ESR_OK && pred.n_triangles == 0)
        rc = ESR_FAIL("the model's SDF has no zero crossing: no surface to compare with %s", gt_path);
    if (rc == ESR_OK)
        rc = esr_chamfer_meshes(&pred, &gt, ESR_GEOMETRY_SAMPLES, 1, out);
    esr_mesh_free(&pred);
    esr_mesh_free(&gt);
    return rc;
}

int esr_geometry_write_json(const char *path, const char *gt_path, const struct esr_chamfer_result *r)
{
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return ESR_FAIL("%s: out of memory", path);
    cJSON_AddStringToObject(root, "gt_mesh", gt_path);
    cJSON_AddNumberToObject(root, "samples", (double)r->n_samples);
    cJSON_AddNumberToObject(root, "accuracy", r->accuracy);
    cJSON_AddNumberToObject(root, "completeness", r->completeness);
    cJSON_AddNumberToObject(root, "chamfer", r->chamfer);
    return esr_json_write_atomic(path, root);
}
