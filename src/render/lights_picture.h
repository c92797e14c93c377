/* Where each light is, as a picture (`esr lights --picture`): a training photo of the scene with
 * each light's id drawn at its centroid's projection, so the ids `esr edit --light` takes are
 * tied to something the user knows. */
#ifndef ESR_RENDER_LIGHTS_PICTURE_H
#define ESR_RENDER_LIGHTS_PICTURE_H

#include <stddef.h>

#include "io/dataset.h"
#include "io/image.h"
#include "model/lights.h"

/* The picture's width is the photo's times this factor, at least 1, chosen so that it is at
 * least ESR_LIGHTS_PICTURE_MIN_WIDTH pixels wide (pixels repeated: a 32 px photo gives 256). */
#define ESR_LIGHTS_PICTURE_MIN_WIDTH 256
/* The integer factor a photo width wide is enlarged by. */
int esr_lights_picture_scale(int width);

/* out (RGB, allocated here): of ds's training frames, the lights-on one (any one when none is
 * lit) onto which the most of L's centroids project inside the image (the first such), its
 * photo enlarged esr_lights_picture_scale times, each light's id in a black box beside a cross
 * at its centroid's projection (a centroid outside the view gets no mark; occlusion is not
 * tested: a light behind an object is marked where it would be seen). frame [size] gets the
 * frame's name; shown[id] is 1 for the lights marked. ESR_ERR when the dataset has no training
 * frame or its photo cannot be read (the file named). */
int esr_lights_picture(const struct esr_lights *L, const struct esr_dataset *ds,
                       struct esr_image *out, char *frame, size_t size, int shown[ESR_MAX_LIGHTS]);

#endif
