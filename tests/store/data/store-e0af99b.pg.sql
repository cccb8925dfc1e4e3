
SET statement_timeout = 0;
SET lock_timeout = 0;
SET idle_in_transaction_session_timeout = 0;
SET client_encoding = 'UTF8';
SET standard_conforming_strings = on;
SELECT pg_catalog.set_config('search_path', '', false);
SET check_function_bodies = false;
SET xmloption = content;
SET client_min_messages = warning;
SET row_security = off;

SET default_tablespace = '';

SET default_table_access_method = heap;

CREATE TABLE public.bench_trials (
    bench_id character varying(32) NOT NULL,
    seed integer NOT NULL,
    planner character varying(100) NOT NULL,
    run_id character varying(32),
    status character varying(16) NOT NULL,
    valid boolean,
    planning_s double precision,
    execution_s double precision,
    oracle_s double precision,
    queries integer NOT NULL,
    error text,
    finished_at timestamp with time zone NOT NULL
);

CREATE TABLE public.benchmarks (
    id character varying(32) NOT NULL,
    created_at timestamp with time zone NOT NULL,
    finished_at timestamp with time zone,
    status character varying(16) NOT NULL,
    config text NOT NULL
);

CREATE TABLE public.events (
    run_id character varying(32) NOT NULL,
    seq integer NOT NULL,
    t double precision NOT NULL,
    type character varying(32) NOT NULL,
    payload text NOT NULL
);

CREATE TABLE public.runs (
    id character varying(32) NOT NULL,
    scene text NOT NULL,
    seed integer NOT NULL,
    planner character varying(100) NOT NULL,
    config text NOT NULL,
    status character varying(16) NOT NULL,
    created_at timestamp with time zone NOT NULL,
    finished_at timestamp with time zone,
    planning_s double precision,
    execution_s double precision,
    oracle_s double precision,
    queries integer NOT NULL,
    message text NOT NULL,
    plan text,
    owner text
);

CREATE TABLE public.stream_queries (
    id integer NOT NULL,
    run_id character varying(32) NOT NULL,
    node_id integer NOT NULL,
    seq integer NOT NULL,
    stream character varying(200) NOT NULL,
    input_names text NOT NULL,
    inputs text NOT NULL,
    success boolean NOT NULL,
    wall_s double precision NOT NULL,
    cpu_s double precision NOT NULL,
    execution_s double precision NOT NULL,
    error text,
    context text NOT NULL,
    reason text
);

CREATE SEQUENCE public.stream_queries_id_seq
    AS integer
    START WITH 1
    INCREMENT BY 1
    NO MINVALUE
    NO MAXVALUE
    CACHE 1;

ALTER SEQUENCE public.stream_queries_id_seq OWNED BY public.stream_queries.id;

ALTER TABLE ONLY public.stream_queries ALTER COLUMN id SET DEFAULT nextval('public.stream_queries_id_seq'::regclass);

INSERT INTO public.bench_trials VALUES ('d2df8821e3b2', 1, 'baseline', NULL, 'solved', true, 1.5, 2, 0.5, 3, NULL, '2026-12-01 22:29:04.020356+00');

INSERT INTO public.benchmarks VALUES ('d2df8821e3b2', '2026-12-01 22:29:04.010588+00', '2026-12-01 22:29:04.022495+00', 'done', '{"scene":"line-2","planners":["baseline"],"seeds":[1,2],"budget_s":60.0}');

INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 0, 1.1037000149372034e-05, 'run_started', '{"scene":"line-2","seed":1,"planner":"baseline","config":{"budget_s":60.0}}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 1, 0.00042209799903503153, 'node_added', '{"node_id":1,"parent_id":0,"plan_index":0,"depth":1,"stream":"sample-pose","success":true,"outputs":["#p0"],"label":"node 1","output_names":[],"output_labels":[]}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 2, 0.000765097998737474, 'stream_queried', '{"node_id":1,"stream":"sample-pose","input_names":["?b","?r"],"inputs":["b1",[0.0,1.0]],"success":true,"wall_s":0.01,"cpu_s":0.01,"execution_s":0.0,"error":null,"context":{},"reused_from":null,"reason":null,"input_labels":[]}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 3, 0.001116710998758208, 'node_visited', '{"node_id":1,"visits":1,"value":-1.0}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 4, 0.0012324740000622114, 'node_added', '{"node_id":2,"parent_id":1,"plan_index":0,"depth":2,"stream":"sample-pose","success":true,"outputs":["#p1"],"label":"node 2","output_names":[],"output_labels":[]}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 5, 0.0012504999995144317, 'stream_queried', '{"node_id":2,"stream":"sample-pose","input_names":["?b","?r"],"inputs":["b1",[0.0,1.0]],"success":false,"wall_s":0.01,"cpu_s":0.01,"execution_s":0.0,"error":null,"context":{},"reused_from":null,"reason":null,"input_labels":[]}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 6, 0.001269499000045471, 'node_visited', '{"node_id":2,"visits":1,"value":-1.0}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 7, 0.0012797839990525972, 'node_added', '{"node_id":3,"parent_id":2,"plan_index":0,"depth":3,"stream":"sample-pose","success":true,"outputs":["#p2"],"label":"node 3","output_names":[],"output_labels":[]}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 8, 0.0012974900000699563, 'stream_queried', '{"node_id":3,"stream":"sample-pose","input_names":["?b","?r"],"inputs":["b1",[0.0,1.0]],"success":true,"wall_s":0.01,"cpu_s":0.01,"execution_s":0.0,"error":null,"context":{},"reused_from":null,"reason":null,"input_labels":[]}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 9, 0.0013128329992468935, 'node_visited', '{"node_id":3,"visits":1,"value":-1.0}');
INSERT INTO public.events VALUES ('00d10e664bcd4cf698cc2b20096dc838', 10, 0.001321735999226803, 'run_finished', '{"status":"solved","planning_s":1.5,"execution_s":2.0,"oracle_s":0.5,"queries":3,"message":"","valid":null,"plan":null}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 0, 8.982999133877456e-06, 'run_started', '{"scene":"line-2","seed":2,"planner":"baseline","config":{"budget_s":60.0}}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 1, 5.339900053513702e-05, 'node_added', '{"node_id":1,"parent_id":0,"plan_index":0,"depth":1,"stream":"sample-pose","success":true,"outputs":["#p0"],"label":"node 1","output_names":[],"output_labels":[]}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 2, 7.797599937475752e-05, 'stream_queried', '{"node_id":1,"stream":"sample-pose","input_names":["?b","?r"],"inputs":["b1",[0.0,1.0]],"success":true,"wall_s":0.01,"cpu_s":0.01,"execution_s":0.0,"error":null,"context":{},"reused_from":null,"reason":null,"input_labels":[]}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 3, 0.00010324299910280388, 'node_visited', '{"node_id":1,"visits":1,"value":-1.0}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 4, 0.00011356899995007552, 'node_added', '{"node_id":2,"parent_id":1,"plan_index":0,"depth":2,"stream":"sample-pose","success":true,"outputs":["#p1"],"label":"node 2","output_names":[],"output_labels":[]}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 5, 0.00012294199950702023, 'stream_queried', '{"node_id":2,"stream":"sample-pose","input_names":["?b","?r"],"inputs":["b1",[0.0,1.0]],"success":false,"wall_s":0.01,"cpu_s":0.01,"execution_s":0.0,"error":null,"context":{},"reused_from":null,"reason":null,"input_labels":[]}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 6, 0.0001333780001004925, 'node_visited', '{"node_id":2,"visits":1,"value":-1.0}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 7, 0.00013906599997426383, 'node_added', '{"node_id":3,"parent_id":2,"plan_index":0,"depth":3,"stream":"sample-pose","success":true,"outputs":["#p2"],"label":"node 3","output_names":[],"output_labels":[]}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 8, 0.00014706799993291497, 'stream_queried', '{"node_id":3,"stream":"sample-pose","input_names":["?b","?r"],"inputs":["b1",[0.0,1.0]],"success":true,"wall_s":0.01,"cpu_s":0.01,"execution_s":0.0,"error":null,"context":{},"reused_from":null,"reason":null,"input_labels":[]}');
INSERT INTO public.events VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 9, 0.00015711299965914804, 'node_visited', '{"node_id":3,"visits":1,"value":-1.0}');

INSERT INTO public.runs VALUES ('00d10e664bcd4cf698cc2b20096dc838', 'line-2', 1, 'baseline', '{"budget_s":60.0}', 'solved', '2026-12-01 22:29:03.948999+00', '2026-12-01 22:29:03.98544+00', 1.5, 2, 0.5, 3, '', NULL, 'vm:9139:1274294');
INSERT INTO public.runs VALUES ('3e7f65a639be44eb91d3ed4964cb561f', 'line-2', 2, 'baseline', '{"budget_s":60.0}', 'running', '2026-12-01 22:29:03.99579+00', NULL, NULL, NULL, NULL, 0, '', NULL, 'vm:9139:1274294');

INSERT INTO public.stream_queries VALUES (1, '00d10e664bcd4cf698cc2b20096dc838', 1, 2, 'sample-pose', '["?b","?r"]', '["b1",[0.0,1.0]]', true, 0.01, 0.01, 0, NULL, '{}', NULL);
INSERT INTO public.stream_queries VALUES (2, '00d10e664bcd4cf698cc2b20096dc838', 2, 5, 'sample-pose', '["?b","?r"]', '["b1",[0.0,1.0]]', false, 0.01, 0.01, 0, NULL, '{}', NULL);
INSERT INTO public.stream_queries VALUES (3, '00d10e664bcd4cf698cc2b20096dc838', 3, 8, 'sample-pose', '["?b","?r"]', '["b1",[0.0,1.0]]', true, 0.01, 0.01, 0, NULL, '{}', NULL);
INSERT INTO public.stream_queries VALUES (4, '3e7f65a639be44eb91d3ed4964cb561f', 1, 2, 'sample-pose', '["?b","?r"]', '["b1",[0.0,1.0]]', true, 0.01, 0.01, 0, NULL, '{}', NULL);
INSERT INTO public.stream_queries VALUES (5, '3e7f65a639be44eb91d3ed4964cb561f', 2, 5, 'sample-pose', '["?b","?r"]', '["b1",[0.0,1.0]]', false, 0.01, 0.01, 0, NULL, '{}', NULL);
INSERT INTO public.stream_queries VALUES (6, '3e7f65a639be44eb91d3ed4964cb561f', 3, 8, 'sample-pose', '["?b","?r"]', '["b1",[0.0,1.0]]', true, 0.01, 0.01, 0, NULL, '{}', NULL);

SELECT pg_catalog.setval('public.stream_queries_id_seq', 6, true);

ALTER TABLE ONLY public.bench_trials
    ADD CONSTRAINT bench_trials_pkey PRIMARY KEY (bench_id, seed, planner);

ALTER TABLE ONLY public.benchmarks
    ADD CONSTRAINT benchmarks_pkey PRIMARY KEY (id);

ALTER TABLE ONLY public.events
    ADD CONSTRAINT events_pkey PRIMARY KEY (run_id, seq);

ALTER TABLE ONLY public.runs
    ADD CONSTRAINT runs_pkey PRIMARY KEY (id);

ALTER TABLE ONLY public.stream_queries
    ADD CONSTRAINT stream_queries_pkey PRIMARY KEY (id);

CREATE INDEX ix_runs_created_at ON public.runs USING btree (created_at);

CREATE INDEX ix_stream_queries_run_id ON public.stream_queries USING btree (run_id);

CREATE INDEX ix_stream_queries_stream ON public.stream_queries USING btree (stream);

ALTER TABLE ONLY public.bench_trials
    ADD CONSTRAINT bench_trials_bench_id_fkey FOREIGN KEY (bench_id) REFERENCES public.benchmarks(id) ON DELETE CASCADE;

ALTER TABLE ONLY public.events
    ADD CONSTRAINT events_run_id_fkey FOREIGN KEY (run_id) REFERENCES public.runs(id) ON DELETE CASCADE;

ALTER TABLE ONLY public.stream_queries
    ADD CONSTRAINT stream_queries_run_id_fkey FOREIGN KEY (run_id) REFERENCES public.runs(id) ON DELETE CASCADE;

