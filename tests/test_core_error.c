/* The library's error channel keeps the first message and where it came from. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "core/error.h"

static int failing_inner(void) { return ESR_FAIL("inner failure %d", 42); }
static int failing_outer(void)
{
    ESR_TRY(failing_inner());
    return ESR_FAIL("outer failure");
}

static void test_first_error_is_kept(void **state)
{
    (void)state;
    esr_error_clear();
    assert_int_equal(esr_error_pending(), 0);
    assert_string_equal(esr_error_message(), "");
    assert_int_equal(failing_outer(), ESR_ERR);
    assert_int_equal(esr_error_pending(), 1);
    assert_string_equal(esr_error_message(), "inner failure 42");
    assert_non_null(strstr(esr_error_origin(), "test_core_error.c:"));
    esr_error_set(__FILE__, __LINE__, "second");
    assert_string_equal(esr_error_message(), "inner failure 42");
    esr_error_clear();
    assert_int_equal(esr_error_pending(), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_first_error_is_kept)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
