"""The benchmarks' timer: repeated calls for the best time, one call where a call is long."""

import time

from pipeline.studies import bench_model


def counting(seconds):
    calls = []

    def call():
        calls.append(1)
        time.sleep(seconds)
        return len(calls)

    return call, calls


def test_a_short_call_is_repeated_and_a_long_one_timed_once():
    short, short_calls = counting(0.001)
    best, value = bench_model.best_time(short, min_repeats=3, min_seconds=0.01)
    assert len(short_calls) >= 3 and value == len(short_calls) and 0.001 <= best < 0.1
    long, long_calls = counting(bench_model.LONG_CALL)
    best, value = bench_model.best_time(long)
    assert long_calls == [1] and value == 1 and best >= bench_model.LONG_CALL
