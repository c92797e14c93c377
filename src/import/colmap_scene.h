/* Where an imported scene goes in esr's world. COLMAP's world has an arbitrary origin, scale and
 * orientation (DTU's normalised one an arbitrary orientation); esr's datasets have the scene
 * inside about the unit sphere (box [-1.5, 1.5]^3), cameras around radius 4 and +Z up. */
#ifndef ESR_IO_COLMAP_SCENE_H
#define ESR_IO_COLMAP_SCENE_H

#include "import/colmap.h"

/* esr world = scale * rotation * (source world - centre). */
struct esr_scene_frame {
    double centre[3];      /* per-axis median of the sparse points */
    double rotation[3][3]; /* takes the cameras' mean image-up direction to +Z */
    double scale;
    double radius;         /* 90th percentile of the points' distances from centre (source units) */
    int from_points;       /* 0: too few points, centre and radius from the camera centres */
};

/* Chooses the frame from the model's points (at least 10; otherwise the camera centres stand in:
 * their median as centre, radius a quarter of their median distance from it) and registered
 * images: scale = min(1 / radius, 4 / median camera distance), so the bulk of the points fits
 * the unit sphere and the cameras are no further out than esr's datasets put them. */
int esr_colmap_scene_frame(const struct esr_colmap_model *m, struct esr_scene_frame *f);

/* Given f->centre and f->radius, the rest from the cameras (camera-to-world matrices in esr's
 * convention, source world): scale = min(1 / radius, 4 / the cameras' median distance from the
 * centre), rotation taking the cameras' mean image-up to +Z (none when they disagree). Fails when
 * the scale is not finite and positive (a zero or non-finite radius, distances that overflow). */
int esr_scene_frame_place(const double (*c2w)[3][4], int n, struct esr_scene_frame *f);

/* A camera-to-world matrix (esr's convention, COLMAP world) moved into esr's world. */
void esr_scene_frame_apply(const struct esr_scene_frame *f, const double c2w[3][4], double out[3][4]);

#endif
