/* test_interrupt.c — the stop flag of a long command (host/app/interrupt.c). Host only; never
 * skips. Asserts: while installed, SIGINT, SIGTERM and SIGHUP are recorded instead of ending
 * the process, and the handlers before are put back by interrupt_restore; a signal ignored
 * when the handlers are installed (nohup's SIGHUP), or when the process began
 * (interrupt_note_ignored) though a library took it since, stays ignored and is not
 * recorded. */
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "app/interrupt.h"

static void (*handler_of(int sig))(int)
{
    struct sigaction now;
    assert_int_equal(sigaction(sig, NULL, &now), 0);
    return now.sa_handler;
}

static void test_signals_recorded(void **state)
{
    (void)state;
    const int sigs[3] = {SIGINT, SIGTERM, SIGHUP};
    for (int i = 0; i < 3; ++i) {
        signal(sigs[i], SIG_DFL);
        interrupt_install();
        assert_int_equal(interrupt_signal(), 0);
        raise(sigs[i]); /* the default would end the test */
        assert_int_equal(interrupt_signal(), sigs[i]);
        interrupt_restore();
        assert_true(handler_of(sigs[i]) == SIG_DFL);
    }
}

/* Installed: SIGHUP stays ignored (raised, nothing is recorded), `other` is taken. */
static void hup_ignored_other_taken(int other)
{
    interrupt_install();
    assert_true(handler_of(SIGHUP) == SIG_IGN);
    raise(SIGHUP);
    assert_int_equal(interrupt_signal(), 0);
    raise(other);
    assert_int_equal(interrupt_signal(), other);
    interrupt_restore();
}

/* nohup: SIGHUP ignored before the render stays ignored through it; the others are taken. */
static void test_ignored_signal_stays_ignored(void **state)
{
    (void)state;
    signal(SIGHUP, SIG_IGN);
    signal(SIGTERM, SIG_DFL);
    hup_ignored_other_taken(SIGTERM);
    assert_true(handler_of(SIGHUP) == SIG_IGN);
    assert_true(handler_of(SIGTERM) == SIG_DFL);
    signal(SIGHUP, SIG_DFL);
}

/* Noted at the start as main does: a signal ignored then is ignored while installed even
 * when a library has put a handler of its own on it since (PoCL's LLVM does), and that
 * handler is back after interrupt_restore. */
static void other_handler(int sig)
{
    (void)sig;
}

static void test_ignored_at_start_stays_ignored(void **state)
{
    (void)state;
    signal(SIGHUP, SIG_IGN);
    signal(SIGINT, SIG_DFL);
    interrupt_note_ignored();
    signal(SIGHUP, other_handler); /* a library's, after main began */
    hup_ignored_other_taken(SIGINT);
    assert_true(handler_of(SIGHUP) == other_handler);
    signal(SIGHUP, SIG_DFL);
    interrupt_note_ignored(); /* none ignored now */
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_signals_recorded),
                                       cmocka_unit_test(test_ignored_signal_stays_ignored),
                                       cmocka_unit_test(test_ignored_at_start_stays_ignored)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
