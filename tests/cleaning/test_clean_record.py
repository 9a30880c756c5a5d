"""mocapkit.cleaning.clean_record: the record of a cleaning, split out of the pipeline and importable from both."""

import mocapkit.cleaning.clean_record as record
import mocapkit.cleaning.pipeline as pipeline


def test_the_record_names_are_the_pipelines_own():
    # users, tests, benchmarks and docs import CleanResult, clean_path ... from the pipeline: the same objects
    for name in record.__all__:
        assert getattr(pipeline, name) is getattr(record, name), name
    for name in pipeline.__all__:
        assert hasattr(pipeline, name), name
    assert pipeline.clean_path("take/walk.bvh").name == "walk.clean.npz"
    assert str(pipeline.StepRecord("fill", float("nan"), 1, "spline")) == "fill: spline, 1 joint sample changed"
