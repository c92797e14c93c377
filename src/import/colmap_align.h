/* A COLMAP reconstruction compared with the true cameras of the dataset its photos came from
 * (a synthetic capture: `esr synth`'s training renders posed by COLMAP). The reconstruction is
 * known only up to a similarity, so it is first aligned to the truth on the camera centres
 * (core/similarity.h), then each camera's error is measured in the true world: the angle between
 * its axes and the true ones, the distance between the centres. With `esr import colmap
 * --align-to`, that alignment is also the scene's placement, so the imported dataset lives in the
 * true dataset's world (cameras at the true radius, the true test cameras valid as they are). */
#ifndef ESR_IO_COLMAP_ALIGN_H
#define ESR_IO_COLMAP_ALIGN_H

#include "core/similarity.h"
#include "import/colmap.h"
#include "import/colmap_scene.h"
#include "io/dataset.h"

struct esr_colmap_alignment {
    int n_registered;      /* images in the model */
    int n_matched;         /* of those, matched to a true train frame by name */
    int n_true;            /* the true dataset's train frames */
    struct esr_similarity colmap_to_true; /* least squares on the inlier camera centres */
    int n_inliers;         /* matched cameras within inlier_threshold of their true centre */
    double inlier_threshold;              /* true world units */
    double rot_median_deg, rot_max_deg;   /* angle between aligned and true camera axes */
    double pos_median, pos_max;           /* aligned to true camera centre, true world units */
    double scene_radius;                  /* the unit of the *_rel figures (below) */
    double pos_median_rel, pos_max_rel;   /* pos_* / scene_radius */
    double rot_median_inliers_deg, rot_max_inliers_deg; /* the same over the inliers only */
    double pos_median_inliers, pos_max_inliers;
};

/* An inlier's centre lies within this fraction of the scene radius of its true centre. */
#define ESR_ALIGN_INLIER_FRACTION 0.05

/* Matches every registered image to the true train frame whose name (the last component of its
 * file_path) is the image's file name without folder and extension ("on/r_057.jpg" <-> frame
 * "train/r_057"), fits the similarity robustly and measures the errors. A reconstruction can
 * place some cameras wrongly (a symmetric scene, repeated texture), which would drag a plain
 * least-squares fit; so the fit is the one of the 3-camera samples (a fixed pseudo-random set)
 * that most cameras agree with, refitted by least squares on those inliers. The errors are given
 * over every matched camera and over the inliers. The scene radius is half the
 * largest side of scene.json's "bounding_box" "tight_min"/"tight_max" when the true dataset has
 * them (for esr synth's default scene, the floor disc's radius), else 1 (esr's datasets put the
 * scene in the unit sphere). Fails when an image has no true frame of its name (naming it),
 * fewer than 3 match, or the matched centres do not determine a similarity. */
int esr_colmap_align(const struct esr_colmap_model *m, const struct esr_dataset *truth,
                     struct esr_colmap_alignment *a);

/* The placement (esr = scale * rotation * (colmap - centre)) equal to the alignment, so the
 * imported world is the true world. */
/* The scene radius from scene.json's text (size bytes, no NUL needed; name in errors): half the
 * largest side of bounding_box.tight_min/tight_max, 1 without them; a malformed box (not two
 * 3-vectors, min not below max, a side not finite) is an error. */
int esr_colmap_scene_radius_parse(const char *text, size_t size, const char *name, double *radius);

void esr_colmap_alignment_frame(const struct esr_colmap_alignment *a, struct esr_scene_frame *f);

#endif
