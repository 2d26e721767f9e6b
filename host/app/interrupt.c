/* interrupt.c — the stop flag of a long command (interrupt.h). The handler only stores the
 * signal number (async-signal-safe). */
#include "app/interrupt.h"

#include <signal.h>
#include <string.h>

static volatile sig_atomic_t received;
static int installed;
static struct sigaction old_int, old_term, old_hup;

static void on_signal(int sig)
{
    received = sig;
}

void interrupt_install(void)
{
    if (installed) return;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    received = 0;
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    sigaction(SIGHUP, &sa, &old_hup); /* a closed terminal or ssh session, as render */
    installed = 1;
}

void interrupt_restore(void)
{
    if (!installed) return;
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    sigaction(SIGHUP, &old_hup, NULL);
    installed = 0;
}

int interrupt_signal(void)
{
    return received;
}
