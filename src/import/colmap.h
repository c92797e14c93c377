/* COLMAP sparse models: cameras, registered images and 3D points, read from COLMAP's text
 * (cameras.txt, images.txt, points3D.txt) or binary (*.bin, little-endian) files as COLMAP's
 * doc/format.rst describes them. Only what the import needs is kept: intrinsics, poses, names
 * and point positions (not the 2D keypoints or the tracks). */
#ifndef ESR_IO_COLMAP_H
#define ESR_IO_COLMAP_H

#include <stddef.h>
#include <stdint.h>

/* The camera models esr reads, numbered as COLMAP numbers them (the binary files store the
 * number, the text files the name). Other COLMAP models (fisheyes, FULL_OPENCV, ...) are refused. */
enum esr_colmap_model_id {
    ESR_COLMAP_SIMPLE_PINHOLE = 0, /* f, cx, cy */
    ESR_COLMAP_PINHOLE = 1,        /* fx, fy, cx, cy */
    ESR_COLMAP_SIMPLE_RADIAL = 2,  /* f, cx, cy, k */
    ESR_COLMAP_RADIAL = 3,         /* f, cx, cy, k1, k2 */
    ESR_COLMAP_OPENCV = 4,         /* fx, fy, cx, cy, k1, k2, p1, p2 */
    ESR_COLMAP_MODEL_COUNT
};

#define ESR_COLMAP_MAX_PARAMS 8
#define ESR_COLMAP_NAME_MAX 512

struct esr_colmap_camera {
    uint32_t id;
    enum esr_colmap_model_id model;
    int width, height;                     /* pixels, as COLMAP saw the image (EXIF orientation ignored) */
    double params[ESR_COLMAP_MAX_PARAMS];  /* the model's parameters in COLMAP's order, rest 0 */
};

struct esr_colmap_image {
    uint32_t id, camera_id;
    double q[4];                   /* world-to-camera rotation, Hamilton quaternion (w, x, y, z) */
    double t[3];                   /* world-to-camera translation: x_cam = R(q) x_world + t */
    char name[ESR_COLMAP_NAME_MAX]; /* relative to the image folder, e.g. "off/x.jpg" */
};

struct esr_colmap_model {
    int n_cameras, n_images;
    long n_points;
    struct esr_colmap_camera *cameras;
    struct esr_colmap_image *images;
    double *points;                /* n_points * 3: x, y, z of each 3D point */
    const char *format;            /* "text" or "binary" */
};

/* Reads DIR's model: the binary files when DIR/cameras.bin exists, else the text files. Fails
 * naming the file on a missing or malformed file, a truncated or corrupt binary file, a camera
 * model esr does not support, a wrong parameter count, or an image whose camera is not in the
 * model. On failure m is left freed. */
int esr_colmap_model_read(const char *dir, struct esr_colmap_model *m);
int esr_colmap_model_read_text(const char *dir, struct esr_colmap_model *m);
int esr_colmap_model_read_binary(const char *dir, struct esr_colmap_model *m);

/* One model file in memory: its bytes and the name messages give it. */
struct esr_colmap_file {
    const void *data;
    size_t size;
    const char *name;
};
enum { ESR_COLMAP_CAMERAS, ESR_COLMAP_IMAGES, ESR_COLMAP_POINTS, ESR_COLMAP_FILES };

/* The same from the three files' contents in memory (files[ESR_COLMAP_CAMERAS] ...), what the
 * readers above call once they have read DIR's files; the parsers never write to the bytes. An
 * empty file holds no records (the path readers refuse empty files before parsing). */
int esr_colmap_model_parse_text(const struct esr_colmap_file files[ESR_COLMAP_FILES], struct esr_colmap_model *m);
int esr_colmap_model_parse_binary(const struct esr_colmap_file files[ESR_COLMAP_FILES],
                                  struct esr_colmap_model *m);
void esr_colmap_model_free(struct esr_colmap_model *m);

/* The camera with this id, or NULL. */
const struct esr_colmap_camera *esr_colmap_find_camera(const struct esr_colmap_model *m, uint32_t id);

/* Model name <-> number ("OPENCV" <-> 4) and parameter count, for the supported models;
 * esr_colmap_model_from_name returns -1 for any other name. */
const char *esr_colmap_model_name(enum esr_colmap_model_id model);
int esr_colmap_model_from_name(const char *name);
int esr_colmap_model_n_params(enum esr_colmap_model_id model);

/* Checks the parts every reader shares once the three files are parsed: unique camera ids,
 * positive sizes, finite parameters and poses (a quaternion whose squared norm is neither ~0 nor
 * overflows), finite 3D points, every image's camera present. The names are the files' in
 * messages. */
int esr_colmap_model_validate(const struct esr_colmap_model *m, const char *cameras_file, const char *images_file,
                              const char *points_file);

/* How both parsers end: m (format "text" or "binary") takes the three files' records (cameras,
 * images, points3D: arrays of count[i] records, owned from here on), is validated when status is
 * ESR_OK, and is freed when anything failed. Returns the final status. */
int esr_colmap_model_assemble(struct esr_colmap_model *m, const char *format, void *const records[ESR_COLMAP_FILES],
                              const size_t count[ESR_COLMAP_FILES], const struct esr_colmap_file files[ESR_COLMAP_FILES],
                              int status);

#endif
