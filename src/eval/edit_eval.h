/* Relighting evaluated on a dataset's edit phases (test_nvi, test_nvc, test_nvic; the seed's
 * Tables 4-7): each frame's lights[] is the edit (intensity; for colour changes the new hue and
 * saturation, value kept), rendered with the direct or the ratio method (edit/relight.h) or by
 * radiance fine-tuning (edit/finetune.h: frames grouped by edit, one fine-tune each). A frame
 * asking an edit esr cannot make (model/lights.h, esr_light_edit_problem) fails the phase before
 * anything is written. Each esr light takes the edit of the dataset light whose masks hold at
 * least half of its pixels in up to 10 evenly spread frames of the phase (eval/light_split.h,
 * from their light-id renders: the masks are used by evaluation only); one that no dataset light
 * holds so stays as found, and the dataset lights that frames change but no esr light follows
 * are listed (res->unmatched). PSNR and SSIM of the edited render (linear through the sRGB
 * curve, clipped) against the ground-truth PNG on white, per view, mean, and mean per edit
 * asked. Renders go to out_dir as N.png, N.exr, the ground truth (on white) as N_gt.png, and for
 * the mapping's frames N_lights.png. */
#ifndef ESR_EVAL_EDIT_EVAL_H
#define ESR_EVAL_EDIT_EVAL_H

#include "edit/editor.h"
#include "eval/light_split.h"
#include "eval/run_dir.h"
#include "io/dataset.h"
#include "model/model.h"

struct esr_edit_eval_view {
    char name[ESR_NAME_MAX];
    char edit[160]; /* what the frame asks of each dataset light, e.g. "lampshade x0.5; bulb on" */
    double psnr, ssim, seconds;
};

/* The views that asked one edit (the seed's tables score intensity, colour and individual
 * control apart: lamp's "_ind" frames turn one light off and keep the other): views whose edit
 * descriptions match, intensities to 3 significant digits, hue and saturation to 2 decimals. */
struct esr_edit_eval_group {
    char edit[160]; /* as esr_edit_eval_view's */
    int n;
    double psnr, ssim; /* means over its views */
};

struct esr_edit_eval {
    enum esr_phase_id phase;
    enum esr_edit_method method;
    int n;
    struct esr_edit_eval_view *views;
    double psnr, ssim, seconds; /* means */
    int n_groups;
    struct esr_edit_eval_group *groups; /* per distinct edit, in the order views first ask it */
    int spp;                 /* direct, ratio: light samples per pixel and light */
    int n_edits;             /* finetune: distinct edits fine-tuned */
    double finetune_seconds; /* finetune: mean seconds per fine-tune */
    struct esr_light_split split;
    int n_lights;            /* esr's lights (split.dataset_light[0..n_lights) says what each follows) */
    /* dataset lights some frame edits that no esr light follows (no masks, or a light esr did
     * not find): those frames are scored without that edit */
    int n_unmatched;
    int unmatched[ESR_MAX_TRUE_LIGHTS];
    int unmatched_frames[ESR_MAX_TRUE_LIGHTS]; /* frames that edit it */
};

/* Progress of esr_edit_eval_phase, reported after each scored frame. */
struct esr_edit_eval_progress {
    const char *name; /* frame just scored */
    int done, total;
    double psnr;
    int finetuned;    /* finetune: this frame's edit was fine-tuned just now */
};
typedef void (*esr_edit_eval_progress_fn)(void *user, const struct esr_edit_eval_progress *p);

/* How esr_edit_eval_phase relights the frames, and whom it tells. */
struct esr_edit_eval_opts {
    enum esr_edit_method method;
    int spp;                             /* direct, ratio: light samples per pixel and light
                                            (finetune: on the pixels that see a light) */
    const struct esr_finetune_opts *ft;  /* fine-tuning options (NULL: the defaults) */
    esr_edit_eval_progress_fn progress;  /* called after each scored frame, or NULL */
    void *user;                          /* progress's first argument */
};

/* The frames sel selects (sel->ds's phase sel->phase), relit and scored as *opts says. */
int esr_edit_eval_phase(struct esr_model *m, const struct esr_run_selection *sel,
                        const char *out_dir, const struct esr_edit_eval_opts *opts,
                        struct esr_edit_eval *res);
void esr_edit_eval_free(struct esr_edit_eval *res);

/* {"phase", "method": "direct"|"ratio"|"finetune", "spp" (direct, ratio) | "finetunes",
 *  "finetune_seconds" (finetune), "n_views", "views": [{"name", "edit", "psnr", "ssim",
 *  "seconds"}...], "mean": {"psnr", "ssim", "seconds"}, "by_edit": [{"edit", "n_views", "psnr",
 *  "ssim"}...], "light_split": {...}} */
int esr_edit_eval_write_json(const char *path, const struct esr_edit_eval *res);

/* An HTML page: per view the original (orig_href/<camera>_on_linear.png, the test_nv render of the
 * same camera, named by the frame name up to its first '_'), the edit and the ground truth
 * (render_href/N.png, N_gt.png), PSNR and SSIM; the means (all views, and per edit asked) and the
 * light split. */
int esr_edit_eval_write_html(const char *path, const char *title, const struct esr_edit_eval *res,
                             const char *render_href, const char *orig_href);

#endif
