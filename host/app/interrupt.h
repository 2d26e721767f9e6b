/* interrupt.h — SIGINT, SIGTERM and SIGHUP during a long command (render, bake): while installed,
 * the handler only records the signal; the command polls interrupt_signal() at a point where
 * what is finished can be written, stops there, and main() exits with status 3
 * (docs/errors.md). Outside install .. restore the signals have their usual effect. */
#ifndef TS_INTERRUPT_H
#define TS_INTERRUPT_H

/* Notes which of the three signals the process began with ignored: `nohup tessera render ...`
 * (SIGHUP), a render a script starts in the background (SIGINT). Called first in main, before
 * a library can install handlers of its own over them (PoCL's LLVM takes SIGHUP, SIGINT and
 * SIGTERM for its crash handler, which ends the process: under nohup, a closed session ended
 * the render). */
void interrupt_note_ignored(void);
/* Installs the handlers (once; a second call does nothing) and clears the recorded signal. A
 * signal the process began with ignored (interrupt_note_ignored; without that call, one
 * ignored now) is ignored until interrupt_restore instead. */
void interrupt_install(void);
/* Puts the previous handlers back. */
void interrupt_restore(void);
/* The signal received since interrupt_install, or 0. */
int interrupt_signal(void);

#endif
