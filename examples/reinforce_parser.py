"""Fine-tune a question-to-program parser with REINFORCE, rewarded by ``craft_dsl.oracle.run_batch``.

A small GRU encoder-decoder with attention (CPU is enough) is pretrained on a few hundred (question, program
tokens) pairs written by ``craft-dsl export-pairs``, then fine-tuned on answers only, as neuro-symbolic
parsers are: for every question it samples several programs, ``run_batch`` runs them all on the videos'
simulations, and a program's reward is 1 when its answer is the recorded one. It prints, on the questions of
held-out videos, program accuracy (the greedy program is the recorded one) and answer accuracy (the greedy
program's answer is the recorded one) before and after fine-tuning, and the share of the fine-tuning time spent
in the oracle.

    python examples/reinforce_parser.py                       # the full run (docs/oracle.md shows its figures)
    python examples/reinforce_parser.py --dataset my_craft    # questions and simulations of a dataset folder

Without ``--dataset`` it simulates ``--scenes`` videos (scenes 1..20 in turn) and writes them as a dataset
(one question per template with a valid binding on each video). Needs PyTorch:
``pip install torch==2.13.0 'craft-dsl[torch]'``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import random
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from torch import nn

from craft_dsl import CraftError, Program, Simulation
from craft_dsl.cli import main as craft_dsl_main
from craft_dsl.oracle import run_batch

NULL, START, END = 0, 1, 2


@dataclass(frozen=True)
class Config:
    """What the run does; the defaults are the documented full run."""

    scenes: int = 24
    pretrain_pairs: int = 300
    pretrain_epochs: int = 12
    rl_steps: int = 300
    questions_per_step: int = 16
    samples: int = 8
    held_out: float = 0.25
    dim: int = 64
    hidden: int = 128
    lr: float = 3e-3
    rl_lr: float = 5e-4
    max_length: int = 50
    seed: int = 0
    threads: int = 1


@dataclass
class Item:
    """One question: its tokens as indexes, the recorded program tokens and answer, and its simulation."""

    question: list[int]
    program: list[str]
    answer: Any
    sim: Simulation


# -- data ----------------------------------------------------------------------------------------------------


def build_dataset(scenes: int, seed: int, out: Path) -> None:
    """Simulate ``scenes`` videos and write ``dataset.json`` and ``annotations.json`` into ``out``."""
    from craft_dsl.physics import simulate
    from craft_dsl.verify import build_dataset as fixture_dataset

    sims = [simulate(k % 20 + 1, seed=seed + k // 20) for k in range(scenes)]
    dataset, annotations = fixture_dataset(sims)
    out.mkdir(parents=True, exist_ok=True)
    (out / "dataset.json").write_text(json.dumps(dataset))
    (out / "annotations.json").write_text(json.dumps(annotations))


def load_items(folder: Path, work: Path) -> tuple[list[dict[str, Any]], dict[str, Any], dict[int, Simulation]]:
    """The pairs ``craft-dsl export-pairs`` writes, the vocabularies ``craft-dsl vocab`` writes, and the
    simulation of every video the pairs name."""
    from craft_dsl.verify.annotations import open_annotations

    pairs_path, vocab_path = work / "pairs.jsonl", work / "vocab.json"
    for argv in (["export-pairs", "--dataset", str(folder), "--out", str(pairs_path)],
                 ["vocab", "--out", str(vocab_path)]):
        if craft_dsl_main(argv) != 0:
            raise CraftError(f"craft-dsl {argv[0]} failed")
    pairs = [json.loads(line) for line in pairs_path.read_text().splitlines() if line.strip()]
    store = open_annotations(folder / "annotations.json")
    sims: dict[int, Simulation] = {}
    for pair in pairs:
        index = pair["video_index"]
        if index not in sims:
            key = store.resolve(f"{index:06d}", index)
            if key is None:
                raise CraftError(f"{folder}: no simulation for video {index}")
            sims[index] = store.simulation(key)
    return pairs, json.loads(vocab_path.read_text()), sims


# -- the parser ------------------------------------------------------------------------------------------------


class Parser(nn.Module):
    """A bidirectional GRU over the question; a GRU decoder over program tokens with dot-product attention."""

    def __init__(self, n_question: int, n_program: int, dim: int, hidden: int) -> None:
        super().__init__()
        self.question_embedding = nn.Embedding(n_question, dim, padding_idx=NULL)
        self.encoder = nn.GRU(dim, hidden // 2, batch_first=True, bidirectional=True)
        self.program_embedding = nn.Embedding(n_program, dim, padding_idx=NULL)
        self.decoder = nn.GRUCell(dim + hidden, hidden)
        self.out = nn.Linear(2 * hidden, n_program)

    def encode(self, questions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        outputs, last = self.encoder(self.question_embedding(questions))
        return outputs, questions != NULL, torch.cat([last[0], last[1]], dim=-1)

    def step(self, token: torch.Tensor, state: torch.Tensor, context: torch.Tensor, outputs: torch.Tensor,
             mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        state = self.decoder(torch.cat([self.program_embedding(token), context], dim=-1), state)
        scores = torch.bmm(outputs, state.unsqueeze(-1)).squeeze(-1).masked_fill(~mask, float("-inf"))
        context = torch.bmm(torch.softmax(scores, dim=-1).unsqueeze(1), outputs).squeeze(1)
        return self.out(torch.cat([state, context], dim=-1)), state, context

    def loss(self, questions: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
        """Cross-entropy of the target tokens (``<START>`` first, padded with ``<NULL>``), teacher forced."""
        outputs, mask, state = self.encode(questions)
        context = torch.zeros_like(state)
        losses = []
        for t in range(targets.shape[1] - 1):
            logits, state, context = self.step(targets[:, t], state, context, outputs, mask)
            losses.append(nn.functional.cross_entropy(logits, targets[:, t + 1], ignore_index=NULL, reduction="none"))
        per_token = torch.stack(losses, dim=1)
        return per_token.sum() / (targets[:, 1:] != NULL).sum()

    def decode(self, questions: torch.Tensor, max_length: int, sample: bool) -> tuple[torch.Tensor, torch.Tensor]:
        """Token indexes (``<END>`` and after it: ``<NULL>``) and each sequence's log-probability."""
        outputs, mask, state = self.encode(questions)
        context = torch.zeros_like(state)
        token = torch.full((questions.shape[0],), START, dtype=torch.long)
        done = torch.zeros(questions.shape[0], dtype=torch.bool)
        tokens, log_prob = [], torch.zeros(questions.shape[0])
        for _ in range(max_length):
            logits, state, context = self.step(token, state, context, outputs, mask)
            logp = torch.log_softmax(logits, dim=-1)
            token = torch.multinomial(logp.exp(), 1).squeeze(1) if sample else logp.argmax(dim=-1)
            log_prob = log_prob + torch.where(done, 0.0, logp.gather(1, token.unsqueeze(1)).squeeze(1))
            tokens.append(torch.where(done, NULL, token))
            done = done | (token == END)
            if bool(done.all()):
                break
        return torch.stack(tokens, dim=1), log_prob


def pad(rows: Sequence[Sequence[int]]) -> torch.Tensor:
    width = max(len(r) for r in rows)
    return torch.tensor([list(r) + [NULL] * (width - len(r)) for r in rows], dtype=torch.long)


def to_tokens(rows: torch.Tensor, names: list[str]) -> list[list[str]]:
    """Decoded indexes -> program tokens (up to ``<END>``; special tokens other than it are kept, so that a
    program holding one is a syntax error, as it would be for a model's output)."""
    out = []
    for row in rows.tolist():
        tokens = []
        for i in row:
            if i in (END, NULL):
                break
            tokens.append(names[i])
        out.append(tokens)
    return out


# -- scoring --------------------------------------------------------------------------------------------------------


def accuracies(model: Parser, items: list[Item], names: list[str], config: Config) -> tuple[float, float]:
    """(program accuracy, answer accuracy) of the greedy programs."""
    model.eval()
    with torch.no_grad():
        decoded, _ = model.decode(pad([it.question for it in items]), config.max_length, sample=False)
    programs = to_tokens(decoded, names)
    exact = 0
    for tokens, item in zip(programs, items):
        with contextlib.suppress(CraftError):  # a decoded sequence that is no program
            exact += Program.from_tokens(tokens).key == Program.from_tokens(item.program).key
    answers = run_batch(programs, [it.sim for it in items], form="prefix").rewards([it.answer for it in items])
    return exact / len(items), float(answers.mean())


def pretrain(model: Parser, items: list[Item], index: dict[str, int], config: Config, rng: random.Random) -> None:
    optimiser = torch.optim.Adam(model.parameters(), lr=config.lr)
    model.train()
    for _ in range(config.pretrain_epochs):
        order = list(range(len(items)))
        rng.shuffle(order)
        for start in range(0, len(order), 32):
            chunk = [items[i] for i in order[start:start + 32]]
            targets = pad([[START, *(index[t] for t in it.program), END] for it in chunk])
            loss = model.loss(pad([it.question for it in chunk]), targets)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()


def reinforce(model: Parser, items: list[Item], names: list[str], config: Config,
              rng: random.Random) -> dict[str, float]:
    """REINFORCE on answers only, with the mean reward of a question's samples as its baseline."""
    optimiser = torch.optim.Adam(model.parameters(), lr=config.rl_lr)
    oracle = 0.0
    scored = 0
    rewarded = 0.0
    t0 = time.perf_counter()
    for _ in range(config.rl_steps):
        chunk = rng.sample(items, min(config.questions_per_step, len(items)))
        questions = pad([it.question for it in chunk]).repeat_interleave(config.samples, dim=0)
        model.train()
        decoded, log_prob = model.decode(questions, config.max_length, sample=True)
        programs = to_tokens(decoded, names)
        t = time.perf_counter()
        result = run_batch(programs, [it.sim for it in chunk for _ in range(config.samples)], form="prefix")
        rewards = result.rewards([it.answer for it in chunk for _ in range(config.samples)])
        oracle += time.perf_counter() - t
        scored += len(programs)
        reward = torch.tensor(rewards, dtype=torch.float32).view(len(chunk), config.samples)
        rewarded += float(reward.mean())
        advantage = (reward - reward.mean(dim=1, keepdim=True)).view(-1)
        loss = -(advantage * log_prob).mean()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    total = time.perf_counter() - t0
    return {"programs_scored": scored, "oracle_seconds": oracle, "fine_tune_seconds": total,
            "oracle_share": oracle / total if total else 0.0, "mean_reward": rewarded / max(config.rl_steps, 1)}


# -- the run ---------------------------------------------------------------------------------------------------------


def run(config: Config, dataset: Path | None = None, verbose: bool = True) -> dict[str, Any]:
    """Pretrain, measure, fine-tune, measure; returns the figures it prints."""
    say = print if verbose else (lambda *a, **k: None)
    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    rng = random.Random(config.seed)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        folder = dataset
        if folder is None:
            folder = work / "dataset"
            build_dataset(config.scenes, config.seed, folder)
        pairs, vocab, sims = load_items(folder, work)
    q_index: dict[str, int] = vocab["question_token_to_idx"]
    p_index: dict[str, int] = vocab["program_token_to_idx"]
    names = [""] * len(p_index)
    for token, i in p_index.items():
        names[i] = token
    unknown = q_index["<UNK>"]
    items = [Item([q_index.get(t, unknown) for t in p["question_tokens"]], p["program_tokens"], p["answer"],
                  sims[p["video_index"]]) for p in pairs]
    videos = sorted(sims)
    rng.shuffle(videos)
    held = set(videos[:max(1, round(len(videos) * config.held_out))])
    test = [it for it, p in zip(items, pairs) if p["video_index"] in held]
    train = [it for it, p in zip(items, pairs) if p["video_index"] not in held]
    rng.shuffle(train)
    supervised = train[:config.pretrain_pairs]
    say(f"{len(pairs)} (question, program) pairs from {len(sims)} videos: {len(supervised)} pretraining pairs, "
        f"{len(train)} training questions (answers only), {len(test)} held-out questions ({len(held)} videos)")

    model = Parser(len(q_index), len(p_index), config.dim, config.hidden)
    t0 = time.perf_counter()
    pretrain(model, supervised, p_index, config, rng)
    pretrain_seconds = time.perf_counter() - t0
    before = accuracies(model, test, names, config)
    say(f"after pretraining ({config.pretrain_epochs} epochs, {pretrain_seconds:.1f} s): "
        f"program accuracy {before[0]:.1%}, answer accuracy {before[1]:.1%}")
    stats = reinforce(model, train, names, config, rng)
    after = accuracies(model, test, names, config)
    say(f"after REINFORCE ({config.rl_steps} steps x {config.questions_per_step} questions x {config.samples} "
        f"samples, {stats['fine_tune_seconds']:.1f} s): program accuracy {after[0]:.1%}, answer accuracy "
        f"{after[1]:.1%}")
    say(f"oracle: {stats['programs_scored']:,} programs scored in {stats['oracle_seconds']:.2f} s, "
        f"{stats['oracle_share']:.1%} of the fine-tuning time "
        f"({stats['programs_scored'] / max(stats['oracle_seconds'], 1e-9):,.0f} programs/s)")
    return {"pairs": len(pairs), "pretrain_pairs": len(supervised), "train_questions": len(train),
            "held_out_questions": len(test), "program_accuracy_before": before[0],
            "answer_accuracy_before": before[1], "program_accuracy_after": after[0],
            "answer_accuracy_after": after[1], **stats}


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", type=Path, help="a dataset folder (dataset.json and annotations.json); default: "
                                                  "simulate --scenes videos")
    defaults = Config()
    for name, value in vars(defaults).items():
        ap.add_argument(f"--{name.replace('_', '-')}", type=type(value), default=value, help=f"default {value}")
    args = vars(ap.parse_args(argv))
    dataset = args.pop("dataset")
    run(Config(**args), dataset)
    return 0


if __name__ == "__main__":
    sys.exit(main())
