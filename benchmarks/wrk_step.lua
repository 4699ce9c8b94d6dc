-- wrk script: each connection steps its own plan (run wrk with as many threads as
-- connections, so that each Lua state drives one connection), with 10 random dynamic
-- obstacles per step and seq counting up from 0. Arguments after `--`: the file holding one
-- plan id per line, then "echo" to post the same bodies to a bare /echo endpoint instead.
local count = 0

function setup(thread)
   thread:set("index", count)
   count = count + 1
end

function init(args)
   local ids = {}
   for line in io.lines(args[1]) do
      table.insert(ids, line)
   end
   plan_id = ids[(index % #ids) + 1]
   echo = args[2] == "echo"
   seq = 0
   math.randomseed(index + 1)
   wrk.headers["Content-Type"] = "application/json"
end

function request()
   local cells = {}
   for i = 1, 10 do
      cells[i] = string.format("[%d,%d]", math.random(0, 1023), math.random(0, 1023))
   end
   local body = string.format('{"seq":%d,"dynamic_obstacles":[%s]}', seq, table.concat(cells, ","))
   seq = seq + 1
   local path = "/plan/" .. plan_id .. "/step"
   if echo then
      path = "/echo"
   end
   return wrk.format("POST", path, nil, body)
end
