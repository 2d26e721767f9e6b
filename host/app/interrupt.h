/* interrupt.h — SIGINT, SIGTERM and SIGHUP during a long command (render, bake): while installed,
 * the handler only records the signal; the command polls interrupt_signal() at a point where
 * what is finished can be written, stops there, and main() exits with status 3
 * (docs/errors.md). Outside install .. restore the signals have their usual effect. */
#ifndef TS_INTERRUPT_H
#define TS_INTERRUPT_H

/* Installs the handlers (once; a second call does nothing) and clears the recorded signal. */
void interrupt_install(void);
/* Puts the previous handlers back. */
void interrupt_restore(void);
/* The signal received since interrupt_install, or 0. */
int interrupt_signal(void);

#endif
