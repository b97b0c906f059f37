"""Verifiable rewards with the signature of TRL's reward functions (craft_dsl.harness.rewards), and rows to train
on (craft_dsl.harness.training). The last test runs TRL's GRPOTrainer when trl is installed."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.errors import CraftError
from craft_dsl.harness.rewards import (
    ANSWER_RIGHT,
    ANSWER_WRONG,
    FORMAT_EXACT,
    FORMAT_NONE,
    FORMAT_READABLE,
    PROGRAM_GRADES,
    PROGRAM_INVALID,
    PROGRAM_RIGHT,
    PROGRAM_SYNTAX_ERROR,
    PROGRAM_TYPE_ERROR,
    PROGRAM_WRONG,
    FormatReward,
    ProgramReward,
    answer_reward,
    extract_program,
    format_reward,
)
from craft_dsl.harness.training import PROGRAM_PROMPT, training_rows
from craft_dsl.oracle import OUTCOMES, run_batch
from craft_dsl.program import Program
from craft_dsl.verify import answers_agree


@pytest.fixture(scope="module")
def rows(users_dataset: Path) -> list[dict[str, Any]]:
    return training_rows(users_dataset, split="random", part="train", task="program")


@pytest.fixture(scope="module")
def program_reward(users_dataset: Path) -> ProgramReward:
    return ProgramReward(users_dataset)


def _columns(rows: list[dict[str, Any]]) -> dict[str, list[Any]]:
    """The keyword arguments TRL passes: every column but the prompt, one entry per completion."""
    return {k: [r[k] for r in rows] for k in rows[0] if k != "prompt"}


def test_grades_are_ordered() -> None:
    assert PROGRAM_SYNTAX_ERROR < PROGRAM_TYPE_ERROR < PROGRAM_INVALID < PROGRAM_WRONG < PROGRAM_RIGHT
    assert list(PROGRAM_GRADES) == ["syntax_error", "type_error", "invalid", "wrong_answer", "right_answer"]
    assert ANSWER_WRONG < ANSWER_RIGHT and FORMAT_NONE < FORMAT_READABLE < FORMAT_EXACT
    assert answer_reward.__name__ == "craft_answer" and format_reward.__name__ == "craft_format_plain"


def test_training_rows(rows: list[dict[str, Any]], users_dataset: Path) -> None:
    assert rows and all(r["prompt"] == PROGRAM_PROMPT.format(question=r["question"]) for r in rows)
    assert all(Program.parse(r["program"]) for r in rows)
    chat = training_rows(users_dataset, part="test", task="answer", chat=True)
    assert chat[0]["prompt"][0]["role"] == "user" and chat[0]["question"] in chat[0]["prompt"][0]["content"]
    with pytest.raises(CraftError, match="unknown task 'caption'; allowed: answer, program"):
        training_rows(users_dataset, task="caption")
    with pytest.raises(CraftError, match="unknown part 'dev'"):
        training_rows(users_dataset, part="dev")


def test_the_recorded_program_earns_the_top_grade(rows: list[dict[str, Any]], program_reward: ProgramReward) -> None:
    rewards = program_reward([r["prompt"] for r in rows], [r["program"] for r in rows], **_columns(rows))
    assert rewards == [PROGRAM_RIGHT] * len(rows)


def test_each_outcome_gets_its_grade(rows: list[dict[str, Any]], program_reward: ProgramReward) -> None:
    row = rows[0]
    sim = program_reward.simulation(row["video_index"])
    wrong = next(p for p in ("Count(SceneAtStart())", "Count(Events())", "Count(FilterDynamic(SceneAtStart()))")
                 if not answers_agree(Program.parse(p).run(sim), row["answer"]))
    nodes = json.dumps(Program.parse(row["program"]).to_nodes())
    completions: list[Any] = [
        "Count(FilterColor(",                                    # syntax error
        "Count(Frobnicate(SceneAtStart()))",                     # unknown module: syntax error
        "",                                                      # nothing: syntax error
        "[1, 2]",                                                # JSON that is no program: syntax error
        'Count(FilterColor(SceneAtStart(), "pink"))',            # a value outside the vocabulary: type error
        "FilterColor(SceneAtStart(), \"red\")",                  # an ObjectSet is no answer: type error
        "QueryColor(Unique(SceneAtStart()))",                    # Unique of several objects: INVALID
        wrong,                                                   # another answer
        row["program"],                                          # the answer
        f"<think>It counts.</think>\n```\n{row['program']}\n```",  # fenced, after reasoning
        f"Program: {row['program']}",
        f"```json\n{nodes}\n```",                                # a node list
        [{"role": "assistant", "content": f"<program>{row['program']}</program>"}],  # a chat completion
    ]
    n = len(completions)
    kwargs = {"video_index": [row["video_index"]] * n, "answer": [row["answer"]] * n}
    got = program_reward(None, completions, **kwargs)
    assert got == [PROGRAM_SYNTAX_ERROR] * 4 + [PROGRAM_TYPE_ERROR] * 2 + [PROGRAM_INVALID, PROGRAM_WRONG] + \
        [PROGRAM_RIGHT] * 5


def test_program_rewards_are_run_batch_outcomes(rows: list[dict[str, Any]], program_reward: ProgramReward) -> None:
    """On edited programs of every form: each reward is the grade of run_batch's outcome for that program alone."""
    completions: list[str] = []
    for r in rows[:40]:
        text = r["program"]
        completions += [text, text.replace("Count", "Cnt", 1), text.replace('"', "", 2), text[:-1],
                        text.replace("SceneAtStart", "SceneAtEnd")]
    expanded = [r for r in rows[:40] for _ in range(5)]
    kwargs = _columns(expanded)
    rewards = program_reward(None, completions, **kwargs)
    for completion, r, reward in zip(completions, expanded, rewards):
        result = run_batch([completion], program_reward.simulation(r["video_index"]))
        kind = OUTCOMES[int(result.codes[0])]
        if kind == "answer":
            kind = "right_answer" if answers_agree(result.answers[0], r["answer"]) else "wrong_answer"
        assert reward == PROGRAM_GRADES[kind], completion
    assert len(set(rewards)) >= 3


def test_token_forms(rows: list[dict[str, Any]], users_dataset: Path) -> None:
    row = rows[0]
    program = Program.parse(row["program"])
    for order in ("prefix", "postfix"):
        reward = ProgramReward(users_dataset, form=order)
        tokens = " ".join(program.to_tokens(order))
        assert reward(None, [tokens, tokens + " Cnt"], video_index=[row["video_index"]] * 2,
                      answer=[row["answer"]] * 2) == [PROGRAM_RIGHT, PROGRAM_SYNTAX_ERROR]
    assert extract_program(json.dumps(program.to_tokens("prefix"))) == program.to_tokens("prefix")
    with pytest.raises(CraftError, match="unknown program form 'tokens'"):
        ProgramReward(users_dataset, form="tokens")


def test_simulations_from_a_mapping_and_clear_errors(rows: list[dict[str, Any]], program_reward: ProgramReward) -> None:
    row = rows[0]
    mapping = ProgramReward({row["video_index"]: program_reward.simulation(row["video_index"])})
    assert mapping(None, [row["program"]], video_index=[row["video_index"]], answer=[row["answer"]]) == [1.0]
    with pytest.raises(CraftError, match="no simulation for video 999"):
        mapping(None, [row["program"]], video_index=[999], answer=[row["answer"]])
    with pytest.raises(CraftError, match="the dataset has no column 'video_index'"):
        program_reward(None, [row["program"]], answer=[row["answer"]])
    with pytest.raises(CraftError, match="column 'answer' has 2 entries for 1 completions"):
        program_reward(None, [row["program"]], video_index=[0], answer=["1", "2"])
    with pytest.raises(CraftError, match="must be a dataset folder"):
        ProgramReward(42)  # type: ignore[arg-type]


def test_simulations_are_kept_between_calls(rows: list[dict[str, Any]], users_dataset: Path) -> None:
    first, second = sorted({r["video_index"] for r in rows})[:2]
    reward = ProgramReward(users_dataset, cache=1)
    sim = reward.simulation(first)
    assert reward.simulation(first) is sim  # kept, with the counterfactual runs computed on it
    reward.simulation(second)
    assert list(reward._cache) == [second]  # one kept: the least recently used went


def test_answer_reward(rows: list[dict[str, Any]]) -> None:
    kinds = {r["answer_kind"]: r for r in rows}
    count, boolean = kinds["count"], kinds["bool"]
    other = "False" if boolean["answer"] == "True" else "True"
    completions: list[Any] = [f"The answer is {count['answer']}.", "I cannot tell.", f"**{boolean['answer']}**",
                              other, [{"role": "assistant", "content": f"Answer: {boolean['answer'].lower()}"}]]
    columns = {"answer": [count["answer"], count["answer"], boolean["answer"], boolean["answer"], boolean["answer"]],
               "template_id": [count["template_id"]] * 2 + [boolean["template_id"]] * 3}
    assert answer_reward(None, completions, **columns) == [1.0, 0.0, 1.0, 0.0, 1.0]
    by_kind = {"answer": columns["answer"], "answer_kind": ["count"] * 2 + ["bool"] * 3}
    assert answer_reward(None, completions, **by_kind) == [1.0, 0.0, 1.0, 0.0, 1.0]
    with pytest.raises(CraftError, match="no column 'answer'"):
        answer_reward(None, ["2"], template_id=["descriptive_0"])


def test_format_reward() -> None:
    completions = ["2", "2.", "two", "The answer is 2.", "I cannot tell.", "Red", "yes", "True", "<answer>2</answer>"]
    kinds = ["count", "count", "count", "count", "count", "color", "bool", "bool", "count"]
    assert format_reward(None, completions, answer_kind=kinds) == [
        FORMAT_EXACT, FORMAT_EXACT, FORMAT_READABLE, FORMAT_READABLE, FORMAT_NONE, FORMAT_EXACT, FORMAT_EXACT,
        FORMAT_EXACT, FORMAT_READABLE]
    tagged = FormatReward("tagged")
    assert tagged(None, ["<think>two fall</think><answer>2</answer>", "<answer> 2 </answer>", "2",
                         "<answer>2</answer> more", "<answer>maybe</answer>"],
                  answer_kind=["count"] * 5) == [FORMAT_EXACT, FORMAT_EXACT, FORMAT_READABLE, FORMAT_READABLE,
                                                 FORMAT_NONE]
    assert tagged.__name__ == "craft_format_tagged"
    with pytest.raises(CraftError, match="unknown format style 'json'; allowed: plain, tagged"):
        FormatReward("json")


# -- TRL's GRPOTrainer (installed apart: docs/train.md) ----------------------------------------------------------


def _trl_missing() -> str | None:
    for name in ("trl", "transformers", "datasets", "tokenizers"):
        if importlib.util.find_spec(name) is None:
            return f"{name} is not installed (pip install trl; see docs/train.md)"
    return None


class _Recorder:
    """A reward function that records what TRL passed it and what it returned."""

    def __init__(self, reward: Any) -> None:
        self.reward = reward
        self.__name__ = reward.__name__
        self.calls: list[tuple[list[Any], dict[str, Any], list[float]]] = []

    def __call__(self, prompts: Any, completions: Any, **kwargs: Any) -> list[float]:
        out = self.reward(prompts, completions, **kwargs)
        self.calls.append((list(completions), dict(kwargs), list(out)))
        return out


@pytest.mark.skipif(_trl_missing() is not None, reason=str(_trl_missing()))
def test_grpo_trainer_logs_the_rewards_of_direct_calls(rows: list[dict[str, Any]], users_dataset: Path,
                                                       tmp_path: Path) -> None:
    """A few GRPO steps on CPU with a tiny model made from a config (no download): the rewards TRL logs are the
    means of what the reward functions give when called directly on the same completions and columns."""
    import torch
    from datasets import Dataset
    from tokenizers import Tokenizer, models, pre_tokenizers
    from transformers import LlamaConfig, LlamaForCausalLM, PreTrainedTokenizerFast
    from trl import GRPOConfig, GRPOTrainer

    torch.manual_seed(0)
    words = sorted({w for r in rows for w in (r["prompt"] + " " + r["program"]).replace("(", " ( ").replace(
        ")", " ) ").replace(",", " , ").split()} | {"2", "True", "red"})
    vocab = {w: i for i, w in enumerate(["<pad>", "<unk>", "<s>", "</s>", *words])}
    core = Tokenizer(models.WordLevel(vocab, unk_token="<unk>"))
    core.pre_tokenizer = pre_tokenizers.WhitespaceSplit()
    tokenizer = PreTrainedTokenizerFast(tokenizer_object=core, pad_token="<pad>", unk_token="<unk>",
                                        bos_token="<s>", eos_token="</s>")
    tokenizer.padding_side = "left"
    model = LlamaForCausalLM(LlamaConfig(vocab_size=len(vocab), hidden_size=32, intermediate_size=64,
                                         num_hidden_layers=1, num_attention_heads=2, num_key_value_heads=2,
                                         max_position_embeddings=512, pad_token_id=0, bos_token_id=2,
                                         eos_token_id=3))
    train = Dataset.from_list([{k: r[k] for k in ("prompt", "answer", "template_id", "video_index")}
                               for r in rows[:8]])
    rewards = [_Recorder(answer_reward), _Recorder(ProgramReward(users_dataset)), _Recorder(format_reward)]
    config = GRPOConfig(output_dir=str(tmp_path), per_device_train_batch_size=4, num_generations=4,
                        max_completion_length=8, max_steps=2, logging_steps=1, learning_rate=1e-4, seed=0,
                        report_to=[], use_cpu=True, save_strategy="no", temperature=1.0, bf16=False)
    trainer = GRPOTrainer(model=model, reward_funcs=rewards, args=config, train_dataset=train,
                          processing_class=tokenizer)
    trainer.train()
    logged = [h for h in trainer.state.log_history if any(k.startswith("rewards/") for k in h)]
    assert len(logged) == 2
    for recorder in rewards:
        assert len(recorder.calls) == 2
        for (completions, kwargs, returned), log in zip(recorder.calls, logged):
            columns = {k: v for k, v in kwargs.items() if k in ("answer", "template_id", "video_index")}
            direct = recorder.reward(None, completions, **columns)
            assert direct == returned
            assert log[f"rewards/{recorder.__name__}/mean"] == pytest.approx(sum(direct) / len(direct))
