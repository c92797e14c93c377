/* `esr synth`: renders a complete ESR-NeRF dataset (FORMAT.md layout) of a built-in scene, plus
 * ground truth images cannot carry (surface mesh, per-view material and emission maps). */
#ifndef ESR_SYNTH_SYNTH_H
#define ESR_SYNTH_SYNTH_H

#include <stdint.h>

#include "synth/photo.h"

#define ESR_SYNTH_RES_MIN 8
#define ESR_SYNTH_RES_MAX 2048
#define ESR_SYNTH_SPP_MIN 1
#define ESR_SYNTH_SPP_MAX 65536

struct esr_synth_progress {
    const char *phase;     /* "train", or "test" (the four test phases, camera by camera) */
    int done, total;       /* frames of this phase written */
    double samples_per_s;  /* path samples per second so far in this phase (of the images
                              rendered: a test camera's frames come from its light basis) */
    double elapsed_s;      /* since the phase started */
};

struct esr_synth_options {
    const char *scene;     /* built-in scene name */
    int res;               /* image width = height; 0 = the scene's default */
    int spp;               /* samples per pixel; 0 = the scene's default */
    int n_train;           /* train views per lighting condition; 0 = the scene's default */
    int n_test;            /* test cameras; 0 = the scene's default */
    uint64_t seed;
    int force;             /* replace a non-empty out_dir */
    int backdrop;          /* 1: cameras see a distant backdrop (alpha 1): "photos" (trace.h) */
    /* train images as an automatic camera takes them (photo.h): opaque (over the backdrop, or
     * white), per-photo exposure and white balance, tone curve; truth in gt/photos.json */
    struct esr_photo_options photo;
    /* Called after every frame written (from the calling thread); may be NULL. */
    void (*progress)(void *user, const struct esr_synth_progress *p);
    void *user;
};

/* Writes the dataset into out_dir through a staging sibling renamed at the end, so out_dir is
 * either absent/old or complete. Fails (removing the staging directory) on bad options, an
 * existing non-empty out_dir without force, or any write error. */
int esr_synth_write_dataset(const char *out_dir, const struct esr_synth_options *opt);

struct esr_synth_bench_result {
    double seconds;
    double samples_per_s;  /* camera samples (one path each) per second */
    double pixels_per_s;   /* finished pixels per second */
    long long samples;
};

/* Renders a fixed workload (the default scene, lights on, 4 views of 64x64 at 16 spp) with all
 * OpenMP threads and reports its throughput. */
int esr_synth_bench(struct esr_synth_bench_result *out);

#endif
