"""Result files: Table I round-trips through CSV, Markdown reads like the paper's, plots are PNGs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.run.report import (
    COLUMNS,
    TableRow,
    plot_ga_convergence,
    plot_gala_convergence,
    read_table_csv,
    write_table_csv,
    write_table_markdown,
)
from optimizer.search.config import GAConfig, GALAConfig
from optimizer.search.ga import GARun
from optimizer.search.gala import GALA
from optimizer.search.protocol import run_sync

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
BOUNDS = np.tile([-1.0, 1.0], (7, 1))


def fitness(genes: np.ndarray) -> float:
    return float(50.0 - 20.0 * np.sum(genes**2))


@pytest.fixture(scope="module")
def gala_result():
    config = GALAConfig(ga=GAConfig(population_size=8, generations=4), iterations=12)
    return run_sync(GALA(BOUNDS, config, 0.8, 0), fitness)


def test_table_i_csv_round_trips_and_markdown_lists_every_row(tmp_path: Path, gala_result) -> None:
    rows = [
        TableRow.from_gala(
            gala_result, distance_m=gala_result.best_fitness / 10, speed_mps=gala_result.best_fitness / 10 / 15
        ),
        TableRow(0.1, 0.08, 12.456, None, None),  # a fallen robot: no distance or speed
        TableRow(0.9, 0.06, -3.25, 0.1 + 0.2, 1 / 3, 10, 2, 0.1 + 0.05, 0.2 + 0.1, 0.7, False),
        TableRow(0.5, 0.02, 80.0, 8.0, 8 / 15, 10, 0, 7.9, 8.0, 8.1, True),
    ]
    write_table_csv(rows, tmp_path / "table1.csv")
    assert read_table_csv(tmp_path / "table1.csv") == rows
    assert (tmp_path / "table1.csv").read_text().splitlines()[0] == ",".join(COLUMNS)

    write_table_markdown(rows, tmp_path / "table1.md")
    lines = (tmp_path / "table1.md").read_text().splitlines()
    assert len(lines) == 2 + len(rows)
    assert lines[0].startswith("| Crossover rate | Optimal mutation rate | Best fitness")
    assert lines[3] == "| 0.10 | 0.08 | 12.4560 | - | - | - | - | - | - | - |"
    assert lines[4] == "| 0.90 | 0.06 | -3.2500 | 0.30 | 0.333 | 2/10 | 0.15 | 0.30 | 0.70 | **FALLS** |"
    assert lines[5].endswith("| 0/10 | 7.90 | 8.00 | 8.10 | yes |")
    assert f"{gala_result.optimal_mutation:.2f}" in lines[2]


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=30, deadline=None)
@given(
    st.lists(
        st.builds(
            TableRow,
            finite,
            finite,
            finite,
            st.none() | finite,
            st.none() | finite,
            st.none() | st.integers(0, 10**6),
            st.none() | st.integers(0, 10**6),
            st.none() | finite,
        ),
        max_size=5,
    )
)
def test_any_table_round_trips_exactly(tmp_path_factory, rows) -> None:
    path = tmp_path_factory.mktemp("t") / "table.csv"
    write_table_csv(rows, path)
    assert read_table_csv(path) == rows


def test_reading_a_foreign_csv_names_the_columns(tmp_path: Path) -> None:
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="expected columns"):
        read_table_csv(tmp_path / "other.csv")


def test_convergence_plots_are_png_files(tmp_path: Path, gala_result) -> None:
    ga_result = run_sync(GARun(BOUNDS, GAConfig(population_size=10, generations=5), 1), fitness)
    plot_ga_convergence(ga_result.history, tmp_path / "ga.png", title="De Jong (0.6, 0.001)")
    plot_gala_convergence(gala_result, tmp_path / "gala.png")
    plot_ga_convergence(gala_result.final_ga_history, tmp_path / "final.png")
    for name in ("ga.png", "gala.png", "final.png"):
        data = (tmp_path / name).read_bytes()
        assert data.startswith(PNG_SIGNATURE), name
        assert len(data) > 5000, name  # axes, lines and labels, not an empty canvas
