"""The GIL is released while registering: other Python threads run, and two registrations run at once.

Neither test compares a time with a bound guessed for this machine: the first looks for the main thread's
progress inside a registration, the second compares the two calls' span with their own C++-measured times.
"""
import threading
import time

import pytest

import mac_registration as mr
from conftest import repo_path

SOURCE = mr.load_cloud(repo_path("data/redkitchen_4_0/source_cloud_bin_4.pcd"))
TARGET = mr.load_cloud(repo_path("data/redkitchen_4_0/target_cloud_bin_0.pcd"))
ONE_THREAD = mr.Config(num_threads=1)  # each registration on one core, so that two can run side by side


def test_python_runs_in_another_thread_during_a_registration():
    interval = {}

    def register():
        interval["start"] = time.perf_counter()
        interval["result"] = mr.register_clouds(SOURCE, TARGET, ONE_THREAD)
        interval["end"] = time.perf_counter()

    worker = threading.Thread(target=register)
    probes = []
    worker.start()
    while worker.is_alive():
        probes.append(time.perf_counter())  # Python bytecode: runs only while the worker does not hold the GIL
    worker.join()
    assert interval["result"].success
    start, end = interval["start"], interval["end"]
    assert end - start > 0.02, "a registration this short cannot tell"
    # Held through the call, the GIL would leave no probe between the call's first and last few
    # milliseconds; released, the main thread runs all along.
    middle = [t for t in probes if start + (end - start) / 4 < t < end - (end - start) / 4]
    assert len(middle) > 10, f"{len(middle)} probes in the middle half of a {1e3 * (end - start):.0f} ms call"


def test_two_registrations_in_two_threads_overlap():
    spans, results = [None, None], [None, None]
    barrier = threading.Barrier(2)

    def register(k):
        barrier.wait()
        start = time.perf_counter()
        results[k] = mr.register_clouds(SOURCE, TARGET, ONE_THREAD)
        spans[k] = (start, time.perf_counter())

    threads = [threading.Thread(target=register, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(r.success for r in results)
    wall = max(end for _, end in spans) - min(start for start, _ in spans)
    # Each call's own C++ wall time, measured inside it. Serialized by the GIL, the calls would take at
    # least the sum of these end to end; run at once (on two cores, or shared on one), about the longer.
    inside = sum(r.times.total_ms for r in results) / 1e3
    print(f"two registrations: {1e3 * wall:.0f} ms end to end, {1e3 * inside:.0f} ms inside the C++ together")
    assert wall < 0.8 * inside, f"the calls did not overlap: {wall:.3f} s end to end, {inside:.3f} s inside"
    # the same pose from both, and as from one thread alone
    alone = mr.register_clouds(SOURCE, TARGET, ONE_THREAD)
    for r in results:
        assert (r.T_target_source == alone.T_target_source).all()


def test_one_described_map_serves_queries_from_several_threads():
    preset = repo_path("config/map_relocalization.yaml")
    config = mr.Config(preset, relocalization_time_limit=600, num_threads=1)
    lidar_map = mr.load_cloud(repo_path("data/lidar/lidar_target_251370668.pcd"))
    query = mr.load_cloud(repo_path("data/lidar/lidar_source_251371071.pcd"))
    described = mr.describe_map(lidar_map, config)
    answers = [None] * 3

    def localize(k):
        answers[k] = mr.relocalize(described, query)

    threads = [threading.Thread(target=localize, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    first = answers[0]
    for answer in answers[1:]:
        assert answer.outcome == first.outcome
        assert (answer.T_map_query == first.T_map_query).all()


if __name__ == "__main__":
    pytest.main([__file__, "-s"])
