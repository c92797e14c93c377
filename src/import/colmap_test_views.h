/* `esr import colmap --align-to TRUE`: the true dataset's novel-view test phase (test_nv) written
 * into the imported dataset, so a run trained on the import is scored by `esr eval --phase
 * test_nv` on exactly the images and cameras a run on the true dataset is scored on. The
 * cameras are copied unchanged because the alignment placed the import in the true world
 * (import/colmap_align.h). Frames are rewritten in the import's convention (one light, "off" or "on")
 * since a dataset's frames must agree on the light count; their PNGs, EXRs and emission masks
 * are copied. */
#ifndef ESR_IO_COLMAP_TEST_VIEWS_H
#define ESR_IO_COLMAP_TEST_VIEWS_H

#include "io/dataset.h"

/* Writes OUT/transforms/transforms_test_nv.json (camera_angle_x as given, which must be the
 * true dataset's: the import writes its photos in the true pinhole) and copies the files into
 * OUT (an existing folder holding transforms/). Fails when the true dataset has no test_nv
 * phase or a file cannot be copied, naming it. *n_views: the frames written. */
int esr_colmap_write_test_views(const struct esr_dataset *truth, double camera_angle_x, const char *out_dir,
                                int *n_views);

#endif
