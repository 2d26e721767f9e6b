/* interrupt.c — the stop flag of a long command (interrupt.h). The handler only stores the
 * signal number (async-signal-safe). */
#include "app/interrupt.h"

#include <signal.h>
#include <string.h>

static volatile sig_atomic_t received;
static int installed, noted;
/* The signals handled; which the process began with ignored (interrupt_note_ignored); whether
 * each was set by interrupt_install, and what it had before. */
static const int handled[3] = {SIGINT, SIGTERM, SIGHUP};
static int ignored[3], taken[3];
static struct sigaction old[3];

static void on_signal(int sig)
{
    received = sig;
}

void interrupt_note_ignored(void)
{
    for (int i = 0; i < 3; ++i) {
        struct sigaction now;
        ignored[i] = sigaction(handled[i], NULL, &now) == 0 && now.sa_handler == SIG_IGN;
    }
    noted = 1;
}

void interrupt_install(void)
{
    if (installed) return;
    struct sigaction sa, ign;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    ign = sa, ign.sa_handler = SIG_IGN;
    received = 0;
    for (int i = 0; i < 3; ++i) { /* SIGHUP: a closed terminal or ssh session, as render */
        taken[i] = sigaction(handled[i], NULL, &old[i]) == 0;
        int skip = noted ? ignored[i] : taken[i] && old[i].sa_handler == SIG_IGN;
        taken[i] = taken[i] && sigaction(handled[i], skip ? &ign : &sa, NULL) == 0;
    }
    installed = 1;
}

void interrupt_restore(void)
{
    if (!installed) return;
    for (int i = 0; i < 3; ++i)
        if (taken[i]) sigaction(handled[i], &old[i], NULL);
    installed = 0;
}

int interrupt_signal(void)
{
    return received;
}
