/* Damaged checkpoints (model/model.h esr_model_load): a truncated copy of the shared tiny run's
 * coarse checkpoint (tests/support/tiny_run.h), one with a wrong magic, and a folder without one
 * are refused with a clear message. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

static void test_corrupt_checkpoints_are_refused(void **state)
{
    (void)state;
    char src[4300], bad[4300];
    snprintf(src, sizeof src, "%s/runs/full/ckpt_coarse.bin", tiny_dir);
    unsigned char *data;
    size_t size;
    assert_int_equal(esr_file_read_all(src, &data, &size), 0);
    snprintf(bad, sizeof bad, "%s/truncated.bin", test_tmpdir);
    assert_int_equal(esr_file_write_atomic(bad, data, size / 2), 0);
    struct esr_model m;
    esr_error_clear();
    assert_int_equal(esr_model_load(&m, bad), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "truncated"));
    esr_error_clear();
    data[0] = 'X';
    snprintf(bad, sizeof bad, "%s/magic.bin", test_tmpdir);
    assert_int_equal(esr_file_write_atomic(bad, data, size), 0);
    assert_int_equal(esr_model_load(&m, bad), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "not an esr checkpoint"));
    esr_error_clear();
    free(data);
    assert_int_equal(esr_model_load(&m, test_tmpdir), ESR_ERR); /* no checkpoint in it */
    assert_non_null(strstr(esr_error_message(), "no checkpoint"));
    esr_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_corrupt_checkpoints_are_refused),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
