// The search tree of one run, folded from its events (planner/events.py) one at a time.
//
// Every applied event returns an undo function, so the page steps back as cheaply as it steps
// forward: the state after events 0..k is reached from the current one by applying or undoing
// the events in between, never by replaying the run from the start.
//
// Tree conventions (planner/events.py): the root is node 0 (parent_id null), never announced
// by the tree search itself, so it exists here from the start; its children are the stream
// plans (depth 0); a node at depth d >= 1 is one result of querying the d-th stream of its
// plan. A stream_queried event names the CHILD node it produced and comes right before that
// child's node_added.

const noop = () => {};

export class SearchTree {
  constructor() {
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
    this.counts = new Map(); // stream -> {ok, failed}
    this.queryWall = 0; // wall seconds of the stream queries so far
    this.predicted = 0; // nodes with a model prediction
    this.predVersion = (this.predVersion ?? 0) + 1; // changes with every prediction set or undone
    this.run = null; // run_started
    this.plans = null; // abstract_plans_found
    this.solution = null; // solution_found
    this.end = null; // run_finished / run_failed / run_cancelled
    this.lastT = 0; // t of the last applied event
    this.layoutDirty = true;
    this.leaves = 1;
    this.maxLevel = 0;
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
      case "node_added":
        return this._nodeAdded(ev);
      case "stream_queried":
        return this._streamQueried(ev);
      case "model_prediction":
        return this._setField(ev.node_id, "pred", ev, (had) => {
          if (!had) this.predicted += 1;
          this.predVersion += 1;
          return () => {
            if (!had) this.predicted -= 1;
            this.predVersion += 1;
          };
        });
      case "node_visited":
        return this._setField(ev.node_id, "visit", ev);
      case "run_started":
        return this._swap("run", ev);
      case "abstract_plans_found":
        return this._swap("plans", ev);
      case "solution_found":
        return this._swap("solution", ev);
      case "run_finished":
      case "run_failed":
      case "run_cancelled":
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
      count = { ok: 0, failed: 0 };
      this.counts.set(ev.stream, count);
    }
    const key = ev.success ? "ok" : "failed";
    count[key] += 1;
    const wall = ev.wall_s || 0;
    this.queryWall += wall;
    return () => {
      count[key] -= 1;
      if (fresh) this.counts.delete(ev.stream);
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

  /** Leaf-order layout: leaves take one slot each, a parent sits over its children. O(n). */
  layout() {
    let next = 0;
    let maxLevel = 0;
    const stack = [this.root];
    const index = [0];
    while (stack.length > 0) {
      const top = stack.length - 1;
      const node = stack[top];
      const i = index[top];
      if (i < node.children.length) {
        index[top] = i + 1;
        stack.push(node.children[i]);
        index.push(0);
        continue;
      }
      stack.pop();
      index.pop();
      const kids = node.children;
      node.x = kids.length === 0 ? next++ : (kids[0].x + kids[kids.length - 1].x) / 2;
      if (node.level > maxLevel) maxLevel = node.level;
    }
    this.leaves = Math.max(next, 1);
    this.maxLevel = maxLevel;
    this.layoutDirty = false;
  }
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
    visit: null, // the latest node_visited event
    x: 0,
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
  tree.predVersion += 1;
  tree.layoutDirty = true;
  return tree;
}
