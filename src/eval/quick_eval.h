/* A quick held-out check of a trained model: renders every test_nv view of a dataset and
 * compares with its PNG (composited on white): PSNR of the tone-mapped output and of the
 * gamma-corrected linear output (clamped to [0,1]), averaged per lighting condition. `esr eval`
 * is the full evaluation (SSIM, HDR MSE, emitter IoU); this serves `esr train --eval`. */
#ifndef ESR_EVAL_QUICK_EVAL_H
#define ESR_EVAL_QUICK_EVAL_H

struct esr_quick_eval {
    double psnr_tone[2]; /* [lights off, on], mean over views */
    double psnr_lin[2];
    int views[2];
};

/* model_path: checkpoint or run directory (esr_model_load). */
int esr_quick_eval_run(const char *model_path, const char *data_dir, struct esr_quick_eval *out);

#endif
