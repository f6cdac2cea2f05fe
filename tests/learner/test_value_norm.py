import torch

from maopg.learner import ValueNorm


def test_statistics_track_the_targets_and_round_trip():
    gen = torch.Generator().manual_seed(0)
    norm = ValueNorm()
    data = [50.0 + 30.0 * torch.randn(200, generator=gen) for _ in range(5)]
    for batch in data:
        norm.update(batch)
    everything = torch.cat(data).double()
    mean, var = norm.mean_var()
    # beta**1000 ≈ 0.99: the running statistics are (nearly) the plain sample statistics.
    assert abs(float(mean) - float(everything.mean())) < 0.5
    assert abs(float(var.sqrt()) - float(everything.std())) < 0.5

    x = torch.linspace(-200.0, 300.0, 11)
    torch.testing.assert_close(norm.denormalize(norm.normalize(x)), x)
    normalized = norm.normalize(everything)
    assert abs(float(normalized.mean())) < 0.02
    assert abs(float(normalized.std()) - 1.0) < 0.02


def test_first_update_is_debiased_and_state_round_trips():
    norm = ValueNorm()
    norm.update(torch.tensor([4.0, 6.0]))
    mean, var = norm.mean_var()
    assert abs(float(mean) - 5.0) < 1e-9
    assert abs(float(var) - 1.0) < 1e-6

    clone = ValueNorm()
    clone.load_state_dict(norm.state_dict())
    x = torch.tensor([0.0, 5.0, 10.0])
    torch.testing.assert_close(clone.normalize(x), norm.normalize(x))
    torch.testing.assert_close(norm.normalize(x), torch.tensor([-5.0, 0.0, 5.0]))


def test_variance_floor_keeps_constant_targets_finite():
    norm = ValueNorm()
    norm.update(torch.full((10,), -7.0))
    out = norm.normalize(torch.tensor([-7.0, -6.0]))
    assert torch.isfinite(out).all()
    torch.testing.assert_close(out, torch.tensor([0.0, 10.0]))
