#pragma once
// SIGTERM, SIGINT and SIGHUP, blocked in every thread and taken by one thread of their own.
//
// METIS (the elimination order of a large factorization) installs a handler of its own for
// SIGTERM while it runs, which jumps back into METIS on the thread that runs it. So a SIGTERM
// that came during a set-up made `hdeform edit` stop with "internal error: METIS nested
// dissection failed", and crashed the editor (its main thread took the signal and jumped to
// nowhere) instead of keeping the session for the next start. A blocked signal reaches no
// handler, whichever one is installed.
namespace hdeform::cli {

// First thing in main(), before any other thread starts: threads inherit the blocked signals.
// Until claim_termination_signals(), a signal ends the process as it would have without this.
void watch_termination_signals();

// The editor's: from now on a signal is recorded (termination_signal()) and `wake` is called on
// the watching thread (to wake a loop that waits for events); one received is then the
// claimant's to act on. Release gives the signals that come later their usual effect.
void claim_termination_signals(void (*wake)());
void release_termination_signals();
// The first signal received while claimed, or 0.
int termination_signal();

}  // namespace hdeform::cli
