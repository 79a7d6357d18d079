"""The lab's tests: its helper, every script of benchmarks/ and experiments/ in quick mode, the studies' collations and the campaign plans."""
