//! `ShutdownSignals` sees a signal that lands while nobody is waiting for it: the chassis bridge
//! once made a fresh `ctrl_c()` future every control tick and lost a Ctrl-C that arrived between
//! two ticks. This file is its own test process, so the signals it sends itself reach only it.

use ros_edge::ShutdownSignals;
use std::time::Duration;

fn send_to_self(signal: libc::c_int) {
    // SAFETY: kill(2) on our own pid with a signal ShutdownSignals has a handler for.
    assert_eq!(unsafe { libc::kill(libc::getpid(), signal) }, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_signal_between_waits_is_not_lost() {
    let mut signals = ShutdownSignals::new().expect("signal handlers");
    for (signal, name) in [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM")] {
        // Busy elsewhere (a control tick) when the signal arrives; only then waiting for it.
        send_to_self(signal);
        tokio::time::sleep(Duration::from_millis(50)).await;
        let got = tokio::time::timeout(Duration::from_secs(5), signals.recv())
            .await
            .unwrap_or_else(|_| panic!("the {name} sent before waiting was lost"));
        assert_eq!(got, name);
    }
}
