// The search tree of one run, folded from its events (planner/events.py) one at a time: the
// page's fold of a live run, by the rules of planner/trace.py's (which compare and the 3D view
// use, and which serves the compare view's trees, treeFromColumns below). Event types are named
// by EVENT (generated from planner/events.py), never by literals.
//
// Every applied event returns an undo function, so the page steps back as cheaply as it steps
// forward: the state after events 0..k is reached from the current one by applying or undoing
// the events in between, never by replaying the run from the start.
//
// Tree conventions (planner/events.py): the root is node 0 (parent_id null), never announced
// by the searches themselves, so it exists here from the start; its children are the stream
// plans (depth 0); a node at depth d >= 1 is one result of querying the d-th stream of its
// plan. A stream_queried event names the CHILD node it produced and comes right before that
// child's node_added. Skeletons come in batches: abstract_plans_found's, then skeletons_added's
// while the search runs (more plan nodes under the root), and skeleton_progress says what the
// skeleton source is doing meanwhile.
//
// Query counts are planner/figures.py's: ok and failed ran a sampler; reused answers (an
// identical earlier query's, reused_from) are counted apart.

import { EVENT, Q_INHERITED } from "/generated/definitions.js";

const noop = () => {};
export const FOLD_MIN = 4; // a node's failed leaves are folded into one fan from this many

export class SearchTree {
  constructor() {
    this.expanded = new Set(); // nodes whose failed fan the user opened (kept across steps)
    this.reset();
  }

  reset() {
    this.root = makeNode(0, null, -1, 0, 0, null, true, [], [], "root");
    this.root.implicit = true; // not announced by a node_added event (yet)
    this.byId = new Map([[0, this.root]]);
    this.order = [this.root]; // insertion order; the root first
    this.added = 0; // node_added events applied
    this.failed = 0; // nodes whose query failed
    this.queries = new Map(); // node id -> its stream_queried event
    this.counts = new Map(); // stream -> {ok, failed, reused}
    this.sampled = 0; // queries a sampler answered (ok + failed): "queries"
    this.reused = 0; // answers reused from an identical earlier query (no sampler ran)
    this.queryWall = 0; // wall seconds of the stream queries so far
    this.predicted = 0; // nodes with a model prediction
    this.predVersion = (this.predVersion ?? 0) + 1; // changes with every prediction set or undone
    this.run = null; // run_started
    this.plans = null; // abstract_plans_found
    this.planList = []; // every skeleton so far: abstract_plans_found's, then skeletons_added's
    this.batches = []; // skeletons_added events so far
    this.skeletonSeconds = 0; // the skeleton source's seconds so far (every batch)
    this.progress = null; // the skeleton source's latest word, while it works (skeleton_progress)
    this.solution = null; // solution_found
    this.end = null; // run_finished / run_failed / run_cancelled
    this.lastT = 0; // t of the last applied event
    this.layoutDirty = true;
    this.leaves = 1;
    this.maxLevel = 0;
    this.fans = []; // folded failed fans, after layout: {parent, nodes, x, level}
    this.rows = []; // per level, after layout: [[name, count], ...] most frequent first
    this.expanded.clear();
  }

  /** Nodes a user sees: every announced node (the implicit root counts once it has children). */
  get nodeCount() {
    return this.root.implicit && this.order.length === 1 ? 0 : this.order.length;
  }

  /** Fold one event into the tree; returns the function that takes it out again. */
  apply(ev) {
    const prevT = this.lastT;
    this.lastT = ev.t ?? prevT;
    const undo = this._apply(ev);
    return () => {
      undo();
      this.lastT = prevT;
    };
  }

  _apply(ev) {
    switch (ev.type) {
      case EVENT.NODE_ADDED:
        return this._nodeAdded(ev);
      case EVENT.STREAM_QUERIED:
        return this._streamQueried(ev);
      case EVENT.MODEL_PREDICTION:
        return this._setField(ev.node_id, "pred", ev, (had) => {
          if (!had) this.predicted += 1;
          this.predVersion += 1;
          return () => {
            if (!had) this.predicted -= 1;
            this.predVersion += 1;
          };
        });
      case EVENT.NODE_VISITED:
        return this._setField(ev.node_id, "visit", ev);
      case EVENT.RUN_STARTED:
        return this._swap("run", ev);
      case EVENT.SKELETON_PROGRESS:
        return this._swap("progress", ev);
      case EVENT.ABSTRACT_PLANS_FOUND:
        return this._skeletons(ev, true);
      case EVENT.SKELETONS_ADDED:
        return this._skeletons(ev, false);
      case EVENT.SOLUTION_FOUND:
        return this._swap("solution", ev);
      case EVENT.RUN_FINISHED:
      case EVENT.RUN_FAILED:
      case EVENT.RUN_CANCELLED:
        return this._swap("end", ev);
      default:
        return noop; // a type this page does not know: nothing to show
    }
  }

  _swap(key, value) {
    const prev = this[key];
    this[key] = value;
    return () => {
      this[key] = prev;
    };
  }

  /** A batch of skeletons: the first (abstract_plans_found) or a later one (skeletons_added). */
  _skeletons(ev, first) {
    const prev = { plans: this.plans, progress: this.progress, n: this.planList.length };
    const plans = ev.plans ?? [];
    for (const plan of plans) this.planList.push({ ...plan, batch: first ? 0 : this.batches.length + 1, at: ev.t });
    if (first) this.plans = ev;
    else this.batches.push(ev);
    this.skeletonSeconds += ev.seconds ?? 0;
    this.progress = null; // the source has answered
    return () => {
      this.planList.length = prev.n;
      if (!first) this.batches.pop();
      this.skeletonSeconds -= ev.seconds ?? 0;
      this.plans = prev.plans;
      this.progress = prev.progress;
    };
  }

  /** A skeleton by its index (any batch), or undefined. */
  plan(index) {
    const list = this.planList;
    const guess = list[index]; // indices are normally their positions
    if (guess && guess.index === index) return guess;
    return list.find((p) => p.index === index);
  }

  _setField(id, key, ev, extra) {
    const node = this.byId.get(id);
    if (node === undefined) return noop;
    const prev = node[key];
    node[key] = ev;
    const more = extra ? extra(prev !== null) : noop;
    return () => {
      node[key] = prev;
      more();
    };
  }

  _streamQueried(ev) {
    const prev = this.queries.get(ev.node_id);
    this.queries.set(ev.node_id, ev);
    let count = this.counts.get(ev.stream);
    const fresh = count === undefined;
    if (fresh) {
      count = { ok: 0, failed: 0, reused: 0 };
      this.counts.set(ev.stream, count);
    }
    const key = queryKind(ev);
    count[key] += 1;
    const sampled = key === "reused" ? 0 : 1;
    this.sampled += sampled;
    this.reused += 1 - sampled;
    const wall = ev.wall_s || 0;
    this.queryWall += wall;
    return () => {
      count[key] -= 1;
      if (fresh) this.counts.delete(ev.stream);
      this.sampled -= sampled;
      this.reused -= 1 - sampled;
      this.queryWall -= wall;
      if (prev === undefined) this.queries.delete(ev.node_id);
      else this.queries.set(ev.node_id, prev);
    };
  }

  _nodeAdded(ev) {
    if (ev.parent_id === null || ev.parent_id === undefined) return this._rootAdded(ev);
    const parent = this.byId.get(ev.parent_id) ?? this.root;
    const node = makeNode(
      ev.node_id,
      parent,
      ev.plan_index,
      ev.depth,
      parent.level + 1,
      ev.stream,
      ev.success,
      ev.outputs,
      ev.output_names,
      ev.label,
      ev.output_labels,
    );
    node.addedAt = ev.t;
    const replaced = this.byId.get(ev.node_id);
    this.byId.set(node.id, node);
    this.order.push(node);
    parent.children.push(node);
    this.added += 1;
    if (!node.success) this.failed += 1;
    this.layoutDirty = true;
    return () => {
      parent.children.pop();
      this.order.pop();
      if (replaced === undefined) this.byId.delete(node.id);
      else this.byId.set(node.id, replaced);
      this.added -= 1;
      if (!node.success) this.failed -= 1;
      this.layoutDirty = true;
    };
  }

  _rootAdded(ev) {
    const root = this.root;
    const prev = { id: root.id, label: root.label, implicit: root.implicit };
    this.byId.delete(root.id);
    root.id = ev.node_id;
    root.label = ev.label || "root";
    root.implicit = false;
    this.byId.set(root.id, root);
    this.added += 1;
    return () => {
      this.byId.delete(root.id);
      Object.assign(root, prev);
      this.byId.set(root.id, root);
      this.added -= 1;
    };
  }

  /** Ids of the nodes from the root to the solution leaf (empty without a solution). */
  solutionPath() {
    const path = new Set();
    if (this.solution === null) return path;
    let node = this.byId.get(this.solution.node_id);
    while (node) {
      path.add(node.id);
      node = node.parent;
    }
    return path;
  }

  /** Open or close the failed fan below node ``id``. */
  toggleFan(id) {
    if (this.expanded.has(id)) this.expanded.delete(id);
    else this.expanded.add(id);
    this.layoutDirty = true;
  }

  /** Open the fan that hides node ``node`` (if one does); true when it did. */
  unfold(node) {
    if (!node?.folded || node.parent === null) return false;
    this.expanded.add(node.parent.id);
    this.layoutDirty = true;
    return true;
  }

  /**
   * Leaf-order layout: leaves take one slot each, a parent sits over its children, and a
   * node's failed leaves (FOLD_MIN or more, unless opened) share one slot, a fan. O(n). Also
   * counts the streams on each row, for the row labels.
   */
  layout() {
    let next = 0;
    let maxLevel = 0;
    const fans = [];
    const rows = [];
    const stack = [this.root];
    const index = [0];
    const kidsOf = [this._kids(this.root)];
    while (stack.length > 0) {
      const top = stack.length - 1;
      const node = stack[top];
      const kids = kidsOf[top];
      const i = index[top];
      if (i < kids.length) {
        index[top] = i + 1;
        const child = kids[i];
        stack.push(child);
        index.push(0);
        kidsOf.push(this._kids(child));
        continue;
      }
      stack.pop();
      index.pop();
      kidsOf.pop();
      const fan = node.fan;
      if (fan !== null) {
        fan.x = next++;
        for (const c of fan.nodes) c.x = fan.x;
        fans.push(fan);
        count(rows, fan.level, fan.nodes[0].stream, fan.nodes.length);
      }
      if (kids.length === 0) node.x = fan === null ? next++ : fan.x;
      else node.x = (kids[0].x + (fan === null ? kids[kids.length - 1].x : fan.x)) / 2;
      if (node.level > maxLevel) maxLevel = node.level;
      count(rows, node.level, rowName(node), 1);
    }
    this.leaves = Math.max(next, 1);
    this.maxLevel = maxLevel;
    this.fans = fans;
    this.rows = rows.map((m) => (m ? [...m.entries()].sort((a, b) => b[1] - a[1]) : []));
    this.layoutDirty = false;
  }

  /** The children laid out one by one; a fan of failed leaves goes to ``node.fan``. */
  _kids(node) {
    const children = node.children;
    node.fan = null;
    if (children.length < FOLD_MIN || this.expanded.has(node.id)) {
      for (const c of children) c.folded = false;
      return children;
    }
    let failed = 0;
    for (const c of children) if (!c.success && c.children.length === 0) failed += 1;
    if (failed < FOLD_MIN) {
      for (const c of children) c.folded = false;
      return children;
    }
    const kids = [];
    const folded = [];
    for (const c of children) {
      const fold = !c.success && c.children.length === 0;
      c.folded = fold;
      (fold ? folded : kids).push(c);
    }
    node.fan = { parent: node, nodes: folded, x: 0, level: node.level + 1 };
    return kids;
  }

  /**
   * Each node's Q for colouring (planner/figures.py): its own prediction's, else its nearest
   * predicted ancestor's, else null, as ``node.effQ``. Parents come before their children in
   * ``order``, so one pass does it; done again only when a prediction or the tree changed.
   */
  effectiveQ() {
    const key = `${this.predVersion}:${this.order.length}`;
    if (this._effKey === key) return;
    for (const node of this.order) {
      let q = node.pred !== null ? node.pred.q : null;
      if (q === null && Q_INHERITED && node.parent !== null) q = node.parent.effQ;
      node.effQ = q;
    }
    this._effKey = key;
  }

  /** Node ``node``'s Q for colouring (see effectiveQ), or null. */
  qOf(node) {
    this.effectiveQ();
    return node.effQ;
  }

  /** The nearest ancestor of ``node`` with a prediction of its own (null: none). */
  predictedAncestor(node) {
    let p = node.parent;
    while (p && p.pred === null) p = p.parent;
    return p ?? null;
  }
}

function count(rows, level, name, n) {
  if (name === null) return;
  let m = rows[level];
  if (m === undefined) m = rows[level] = new Map();
  m.set(name, (m.get(name) ?? 0) + n);
}

/** What a row says of a node on it: its stream (the root and the stream plans by what they are). */
function rowName(node) {
  if (node.parent === null) return "root";
  if (node.stream === null) return "stream plans";
  return node.stream;
}

/** ok, failed or reused (planner/figures.py's query_kind). */
export function queryKind(ev) {
  if (ev.reused_from !== null && ev.reused_from !== undefined) return "reused";
  return ev.success ? "ok" : "failed";
}

function makeNode(
  id, parent, planIndex, depth, level, stream, success, outputs, names, label, valueLabels,
) {
  return {
    id,
    parent,
    children: [],
    planIndex,
    depth,
    level, // rows from the root: 0 root, 1 stream plans, d + 1 results of the d-th stream
    stream,
    success,
    outputs: outputs ?? [],
    outputNames: names ?? [],
    outputLabels: valueLabels ?? [], // the domain's one-line labels of the outputs, if any
    label: label ?? "",
    pred: null, // the latest model_prediction event
    effQ: null, // the Q it is coloured by (SearchTree.effectiveQ)
    visit: null, // the latest node_visited event
    x: 0,
    fan: null, // this node's folded failed leaves, after layout
    folded: false, // drawn inside its parent's fan, after layout
    implicit: false,
  };
}

/**
 * A run's events and a cursor over them: ``step`` is the index of the last applied event,
 * -1 before the first.
 */
export class Replay {
  constructor() {
    this.tree = new SearchTree();
    this.events = [];
    this.undos = [];
  }

  get step() {
    return this.undos.length - 1;
  }

  get last() {
    return this.events.length - 1;
  }

  /** Replace every event (the cursor goes back to the start). */
  load(events) {
    this.tree.reset();
    this.events = events;
    this.undos = [];
  }

  /** Append events that arrived; an event whose seq was seen already is dropped. */
  append(batch) {
    const events = this.events;
    let lastSeq = events.length ? events[events.length - 1].seq : -1;
    for (const ev of batch) {
      if (ev.seq > lastSeq) {
        events.push(ev);
        lastSeq = ev.seq;
      }
    }
  }

  /** Move the cursor so that events 0..k are applied (k is clamped to what exists). */
  goTo(k) {
    const target = Math.max(-1, Math.min(k, this.events.length - 1));
    const tree = this.tree;
    while (this.undos.length - 1 < target) {
      this.undos.push(tree.apply(this.events[this.undos.length]));
    }
    while (this.undos.length - 1 > target) {
      this.undos.pop()();
    }
    return target;
  }
}

/**
 * A whole tree from the columns of GET /api/runs/{id}/tree (the compare view draws it as it
 * is at the end of the run; no stepping, so no undo).
 */
export function treeFromColumns(cols) {
  const tree = new SearchTree();
  const root = tree.root;
  if (cols.ids.length > 0) {
    tree.byId.delete(root.id);
    root.id = cols.ids[0];
    root.label = cols.labels[0] || "root";
    tree.byId.set(root.id, root);
  }
  for (let i = 1; i < cols.ids.length; i++) {
    const parent = tree.byId.get(cols.parents[i]) ?? root;
    const s = cols.streams[i];
    const node = makeNode(
      cols.ids[i],
      parent,
      cols.plans[i],
      cols.depths[i],
      parent.level + 1,
      s >= 0 ? cols.stream_names[s] : null,
      cols.success[i],
      [],
      [],
      cols.labels[i],
    );
    if (cols.q[i] !== null && cols.q[i] !== undefined) {
      node.pred = { q: cols.q[i] };
      tree.predicted += 1;
    }
    tree.byId.set(node.id, node);
    tree.order.push(node);
    parent.children.push(node);
    tree.added += 1;
    if (!node.success) tree.failed += 1;
  }
  if (cols.solution !== null && cols.solution !== undefined) {
    tree.solution = { node_id: cols.solution };
  }
  tree.plans = { plans: cols.plan_list ?? [] };
  tree.planList = [...(cols.plan_list ?? [])];
  tree.predVersion += 1;
  tree.layoutDirty = true;
  return tree;
}
