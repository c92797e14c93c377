/* DTU cameras from cameras_sphere.npz (see dtu_cameras.h). */
#include "import/dtu_cameras.h"

#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "import/projection.h"

/* The 4x4 array `<prefix>_<i>`, named with its photo when absent. */
static int read_mat4(const struct esr_npz *z, const char *prefix, int i, const char *image, double m[16])
{
    char key[64];
    snprintf(key, sizeof key, "%s_%d", prefix, i);
    if (!esr_npz_has(z, key))
        return ESR_FAIL("'%s' has no array '%s' (the camera of '%s')", z->name, key, image);
    return esr_npz_read_matrix(z, key, 4, 4, m);
}

int esr_dtu_camera_read(const struct esr_npz *z, int i, const char *image, struct esr_dtu_camera *out)
{
    double world[16], scale[16], p[3][4];
    ESR_TRY(read_mat4(z, "world_mat", i, image, world));
    ESR_TRY(read_mat4(z, "scale_mat", i, image, scale));
    for (int r = 0; r < 3; r++) /* P = (world_mat @ scale_mat)[:3] */
        for (int c = 0; c < 4; c++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += world[r * 4 + k] * scale[k * 4 + c];
            p[r][c] = s;
        }
    char what[1200];
    snprintf(what, sizeof what, "'%s' camera %d (of '%s')", z->name, i, image);
    struct esr_projection_parts parts;
    ESR_TRY(esr_projection_decompose(p, what, &parts));
    /* the unit sphere's centre (the origin) must be in front: z_cam = R (0 - C) > 0 */
    double depth = -(parts.r[2][0] * parts.centre[0] + parts.r[2][1] * parts.centre[1] +
                     parts.r[2][2] * parts.centre[2]);
    if (!(depth > 0.0))
        return ESR_FAIL("%s looks away from the unit sphere (its centre lies behind the camera)", what);
    memset(&out->k, 0, sizeof out->k);
    out->k.fx = parts.k[0][0];
    out->k.fy = parts.k[1][1];
    out->k.skew = parts.k[0][1];
    out->k.cx = parts.k[0][2];
    out->k.cy = parts.k[1][2];
    static const double flip[3] = {1.0, -1.0, -1.0}; /* OpenCV's +Y down, +Z forward -> esr's */
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            out->c2w[r][c] = parts.r[c][r] * flip[c];
        out->c2w[r][3] = parts.centre[r];
    }
    return ESR_OK;
}
