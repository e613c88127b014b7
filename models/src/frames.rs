//! OSI frame transforms (global -> host vehicle -> sensor). To be written.
